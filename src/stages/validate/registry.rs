//! The list of `compare` metrics: one line per metric, `Variant => Type`,
//! where `Type` implements [`super::metric::ViewMetric`] in its own file.
//! Every view's figures, every placement's means, `compare`'s paired
//! intervals, `compare.csv`'s columns, `report.html`'s tables and
//! docs/formats.md's table of metrics derive from it (docs/layout.md,
//! "Adding a compare metric"). The order is the order of every output.

use super::metric::metrics;

metrics! {
    MseGlossy => super::errors::MseGlossy,
    MseGlossyFiltered => super::errors::MseGlossyFiltered,
    MseGlossyRelative => super::errors::MseGlossyRelative,
    Flip => super::perceptual::Flip,
    UnresolvedFraction => super::work::UnresolvedFraction,
    TexelFetchesPerRay => super::work::TexelFetchesPerRay,
    MseFull => super::errors::MseFull,
}

/// Adding a metric, walked through with a toy: the type in `toy` (its own
/// file in the crate) and the one line `Peak => super::toy::Peak` of a
/// list give it a key, a heading, a slot in every view's and placement's
/// figures (written by key, in the list's order) and a measure.
#[cfg(test)]
mod tests {
    mod toy {
        use crate::stages::validate::metric::{Measure, Show, ViewMetric, ViewRender};

        /// The largest glossy difference of any pixel and channel.
        pub struct Peak;

        impl ViewMetric for Peak {
            const KEY: &'static str = "peak";
            const LABEL: &'static str = "peak error";
            const ABOUT: &'static str = "the largest glossy difference";
            const SHOW: Show = Show::Fixed(2);

            fn measure(v: &ViewRender) -> Measure {
                let peak = v
                    .image
                    .glossy_indirect
                    .iter()
                    .zip(&v.reference.glossy_indirect)
                    .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs() as f64))
                    .fold(0.0, f64::max);
                Measure::Value(peak)
            }
        }
    }

    mod list {
        use crate::stages::validate::metric::metrics;

        metrics! {
            Flip => crate::stages::validate::perceptual::Flip,
            Peak => super::toy::Peak,
        }
    }

    use crate::render::probes::ProbeImage;
    use crate::render::Reference;
    use crate::stages::validate::metric::{Measure, ViewRender};
    use list::{Metric, PerMetric, METRICS};

    #[test]
    fn a_toy_metric_is_one_type_and_one_line_of_the_list() {
        let image = ProbeImage {
            full: vec![[1.0; 3]; 2],
            glossy_indirect: vec![[0.5, 0.25, 0.0], [0.0; 3]],
        };
        let reference = Reference {
            width: 2,
            height: 1,
            full: vec![[1.0; 3]; 2],
            glossy_indirect: vec![[0.0; 3]; 2],
        };
        let view = ViewRender {
            image: &image,
            reference: &reference,
            filtered: &image.glossy_indirect,
            filtered_reference: &reference.glossy_indirect,
            flip_map: &[0.25, 0.75],
            records: &[],
        };
        // Its measure, beside the list's other metric.
        assert!(matches!(Metric::Peak.measure(&view), Measure::Value(v) if v == 0.5));
        assert!(matches!(Metric::Flip.measure(&view), Measure::Pixels(p) if p == [0.25, 0.75]));
        // Its entry: key, heading, and whether compare pairs on it.
        let keys: Vec<&str> = METRICS.iter().map(|m| m.key).collect();
        assert_eq!(keys, ["flip", "peak"]);
        assert_eq!(Metric::Peak.entry().label, "peak error");
        assert_eq!(Metric::paired().collect::<Vec<_>>(), [Metric::Flip]);
        // Its slot in the figures, written by key in the list's order.
        let figures = PerMetric::from_fn(|m| if m == Metric::Peak { 0.5 } else { 0.0 });
        assert_eq!(
            serde_json::to_string(&figures).unwrap(),
            r#"{"flip":0.0,"peak":0.5}"#
        );
        assert_eq!(Metric::Peak.entry().show.cell(0.5), "0.50");
    }

    /// docs/formats.md's table of metrics is this list: a metric added
    /// without its row, or a row left for a removed one, fails here with
    /// the block to paste.
    #[test]
    fn the_metrics_table_is_the_registrys_list() {
        use super::METRICS;
        let mut block =
            String::from("| key | heading in `report.html` | paired | what |\n|---|---|---|---|\n");
        for m in METRICS {
            let paired = if m.paired { "yes" } else { "—" };
            block += &format!("| `{}` | {} | {paired} | {} |\n", m.key, m.label, m.about);
        }
        crate::doc_blocks::assert_doc_block("formats.md", "metrics", &block);
    }
}
