//! Stage 2 (Wang et al. 2019 §3.1): an approximate skeleton of the free
//! space, clustered into initial probe positions.
//!
//! The paper's argument: each element of the scene's straight skeleton sees a
//! region of constant visibility, so one probe per skeleton element covers the
//! scene. The exact 3D straight skeleton is numerically fragile, so the paper
//! offers two approximations, both here and both first-class:
//!
//! | method | file | paper |
//! |---|---|---|
//! | `sdf-skeleton`: cull SDF voxels near surfaces, keep the discrete medial axis | [`mod@sdf_skeleton`] | §3.1 "Signed Distance Function Skeletonization", Fig. 2 |
//! | `medial-axis`: shrink balls from pre-clustered oriented surface points | [`mod@medial_axis`], built on [`surface_points`] and [`ball_shrinking`] | §3.1 "Ball Shrinking Skeletonization", Fig. 3; Ma, Bae, Choi 2012 |
//!
//! Both end the same way ([`cluster`]): skeleton points, largest clearance
//! first, gather the points they see nearby into clusters, one probe each.

pub mod ball_shrinking;
pub mod cluster;
pub mod medial_axis;
pub mod sdf_skeleton;
pub mod surface_points;
