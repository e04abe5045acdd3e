//! Light-field probes (McGuire et al. 2017): spherical maps stored in
//! octahedral squares. This module holds the mapping every probe map shares;
//! refinement already evaluates probes through it (Wang et al. 2019 §3.2
//! derives visibility from "each probe's octahedral directional map").

pub mod octahedral;
