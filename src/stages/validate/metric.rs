//! What a `compare` metric is: one type implementing [`ViewMetric`],
//! listed once in [`super::registry`]. Each view's figure
//! (`compare.json`'s camera rows, `report.json`'s render variants), each
//! placement's mean over views, the paired intervals that call a win
//! (`ratios`), `compare.csv`'s columns, `report.html`'s tables and
//! docs/formats.md's table of metrics all derive from that list
//! (docs/layout.md, "Adding a compare metric").

use crate::gpu::Record;
use crate::render::probes::ProbeImage;
use crate::render::Reference;

/// One validation render and what it is measured against: what every
/// metric reads (Wang et al. 2019 §5.1).
pub struct ViewRender<'a> {
    /// The render through the probes.
    pub image: &'a ProbeImage,
    /// The path-traced reference of the same view.
    pub reference: &'a Reference,
    /// The render's glossy indirect image, box filtered
    /// ([`super::FILTER_RADIUS`]).
    pub filtered: &'a [[f32; 3]],
    /// The reference's glossy indirect image, filtered alike.
    pub filtered_reference: &'a [[f32; 3]],
    /// The ꟻLIP error per pixel of the filtered glossy indirect against
    /// the reference's ([`crate::render::flip`]).
    pub flip_map: &'a [f32],
    /// The glossy rays' records, one per ray.
    pub records: &'a [Record],
}

/// What a metric measures on one view.
pub enum Measure {
    /// One value per pixel, row by row: the view's figure is their mean,
    /// and a paired metric's intervals resample their block means.
    Pixels(Vec<f64>),
    /// The view's figure itself.
    Value(f64),
}

/// How tables print a metric's value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Show {
    /// Scientific, three significant digits (`1.23e-4`): errors spanning
    /// decades.
    Sci,
    /// Fixed point with this many decimals.
    Fixed(usize),
    /// A share, as a percentage with this many decimals.
    Percent(usize),
}

impl Show {
    /// `v` for a table cell of `report.html`.
    pub fn cell(self, v: f64) -> String {
        match self {
            Show::Sci => format!("{v:.3e}"),
            Show::Fixed(d) => format!("{v:.d$}"),
            Show::Percent(d) => format!("{:.d$}%", 100.0 * v),
        }
    }

    /// `v` for a field of `compare.csv`: full precision.
    pub fn csv(self, v: f64) -> String {
        match self {
            Show::Sci => format!("{v:.6e}"),
            Show::Fixed(_) | Show::Percent(_) => format!("{v:.6}"),
        }
    }
}

/// One figure measured on every validation view.
///
/// Contract: [`ViewMetric::measure`] is deterministic in the view; lower
/// is better; a [`ViewMetric::PAIRED`] metric measures
/// [`Measure::Pixels`].
pub trait ViewMetric {
    /// Its key in `compare.json`, `compare.csv` and `report.json`
    /// (`mse_glossy_filtered`).
    const KEY: &'static str;
    /// Its column's heading in `report.html` (`filtered glossy MSE`).
    const LABEL: &'static str;
    /// One line for docs/formats.md's table: what it measures, after whom.
    const ABOUT: &'static str;
    /// How tables print it.
    const SHOW: Show;
    /// Whether `compare` holds rivals against ours on it with paired
    /// bootstrap intervals over pixel blocks, and calls a win only where
    /// every paired metric's interval lies above 1.
    const PAIRED: bool = false;

    /// The figure of one view.
    fn measure(view: &ViewRender) -> Measure;
}

/// A metric of the list, as reports and docs see it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// [`ViewMetric::KEY`].
    pub key: &'static str,
    /// [`ViewMetric::LABEL`].
    pub label: &'static str,
    /// [`ViewMetric::ABOUT`].
    pub about: &'static str,
    /// [`ViewMetric::SHOW`].
    pub show: Show,
    /// [`ViewMetric::PAIRED`].
    pub paired: bool,
}

/// Declares the list of metrics: each line `Variant => Type` makes
/// `Variant` a [`super::registry::Metric`], a slot of every
/// [`super::registry::PerMetric`], and routes its key, heading and
/// measure to `Type`.
macro_rules! metrics {
    ($($variant:ident => $metric:ty),+ $(,)?) => {
        /// A metric of the list in this file; its [`METRICS`] entry
        /// describes it.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[allow(missing_docs)]
        pub enum Metric {
            $($variant,)+
        }

        /// Every metric of the list, in its order.
        pub const METRICS: &[$crate::stages::validate::metric::Entry] = &[
            $($crate::stages::validate::metric::Entry {
                key: <$metric as $crate::stages::validate::metric::ViewMetric>::KEY,
                label: <$metric as $crate::stages::validate::metric::ViewMetric>::LABEL,
                about: <$metric as $crate::stages::validate::metric::ViewMetric>::ABOUT,
                show: <$metric as $crate::stages::validate::metric::ViewMetric>::SHOW,
                paired: <$metric as $crate::stages::validate::metric::ViewMetric>::PAIRED,
            },)+
        ];

        /// How many metrics the list holds.
        pub const COUNT: usize = [$(stringify!($variant)),+].len();

        impl Metric {
            /// Every metric, in the list's order.
            pub const ALL: [Metric; COUNT] = [$(Metric::$variant,)+];

            /// Its entry of [`METRICS`].
            pub fn entry(self) -> &'static $crate::stages::validate::metric::Entry {
                &METRICS[self as usize]
            }

            /// The metrics `compare` pairs rivals on, in order.
            pub fn paired() -> impl Iterator<Item = Metric> {
                Metric::ALL.into_iter().filter(|m| m.entry().paired)
            }

            /// Its measure of `view`.
            pub fn measure(
                self,
                view: &$crate::stages::validate::metric::ViewRender,
            ) -> $crate::stages::validate::metric::Measure {
                use $crate::stages::validate::metric::ViewMetric;
                match self {
                    $(Metric::$variant => <$metric>::measure(view),)+
                }
            }
        }

        /// One `T` per metric of the list, indexed by [`Metric`]; a
        /// `PerMetric<f64>` is written as one field per metric, by key, in
        /// the list's order.
        #[derive(Debug, Clone, PartialEq, Default)]
        pub struct PerMetric<T>(pub [T; COUNT]);

        impl<T> std::ops::Index<Metric> for PerMetric<T> {
            type Output = T;
            fn index(&self, m: Metric) -> &T {
                &self.0[m as usize]
            }
        }

        impl<T> std::ops::IndexMut<Metric> for PerMetric<T> {
            fn index_mut(&mut self, m: Metric) -> &mut T {
                &mut self.0[m as usize]
            }
        }

        impl<T> PerMetric<T> {
            /// `f` of every metric.
            pub fn from_fn(mut f: impl FnMut(Metric) -> T) -> PerMetric<T> {
                PerMetric(std::array::from_fn(|i| f(Metric::ALL[i])))
            }
        }

        impl serde::Serialize for PerMetric<f64> {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                use serde::ser::SerializeMap;
                let mut map = s.serialize_map(Some(COUNT))?;
                for (e, v) in METRICS.iter().zip(&self.0) {
                    map.serialize_entry(e.key, v)?;
                }
                map.end()
            }
        }
    };
}

pub(crate) use metrics;
