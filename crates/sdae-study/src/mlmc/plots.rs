//! SVG plots of an MLMC report, as Giles's `mlmc_test` draws them: log2 of the variance and of
//! the mean per level, N_l per level for each eps, and eps^2 x cost against eps (flat for
//! MLMC at cost O(eps^-2)); with `--qmc` also MLQMC's n_l and variance per randomization per
//! level.

use std::path::Path;

use super::study::MlmcReport;
use crate::error::StudyError;
use crate::plots::figure::{self, Axis, Figure, Point, Series};

/// How an axis's numbers are labelled: as they are, or as the power of 10 they are the
/// logarithm of.
type Format = fn(f64) -> String;

fn plain(v: f64) -> String {
    format!("{v:.0}")
}

fn power_of_ten(v: f64) -> String {
    format!("1e{v:.0}")
}

/// A panel: its title, axis names and formats, and its lines (label, points).
struct Panel {
    title: String,
    axes: (&'static str, &'static str),
    formats: (Format, Format),
    lines: Vec<(String, Vec<(f64, f64)>)>,
}

/// The largest magnitude a panel draws: its values are logarithms (base 2 or 10) of
/// positive finite floats, all within +-1100; anything beyond is not one and is left out, so
/// that an axis is always a finite, bounded range.
const MAX_DRAWN: f64 = 1e4;

/// Whether a panel can draw the point `(x, y)`.
fn drawable((x, y): (f64, f64)) -> bool {
    x.is_finite() && y.is_finite() && x.abs() <= MAX_DRAWN && y.abs() <= MAX_DRAWN
}

/// A padded range of the values that can be drawn (finite, within [`MAX_DRAWN`]).
fn range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && v.abs() <= MAX_DRAWN)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if lo > hi {
        return 0.0..1.0;
    }
    let pad = ((hi - lo) * 0.08).max(0.5);
    lo - pad..hi + pad
}

/// A panel of the figure: linear axes over the drawable points (the values are logarithms).
fn figure_panel(panel: &Panel) -> figure::Panel {
    let points = || {
        panel
            .lines
            .iter()
            .flat_map(|(_, p)| p.iter())
            .filter(|p| drawable(**p))
    };
    let axis = |name: &str, format: Format, range: std::ops::Range<f64>| {
        Axis::linear(name).within(range).formatted(format)
    };
    figure::Panel {
        title: panel.title.clone(),
        x: axis(panel.axes.0, panel.formats.0, range(points().map(|p| p.0))),
        y: axis(panel.axes.1, panel.formats.1, range(points().map(|p| p.1))),
        series: panel
            .lines
            .iter()
            .map(|(label, line)| {
                let finite = line.iter().copied().filter(|p| drawable(*p));
                Series::new(
                    label.clone(),
                    finite.map(|(x, y)| Point::at(x, y)).collect(),
                )
            })
            .collect(),
        guides: Vec::new(),
    }
}

/// Draws `panels` side by side into `path`.
fn draw(path: &Path, title: &str, panels: &[Panel]) -> Result<(), StudyError> {
    let figure = Figure::row(title, panels.iter().map(figure_panel).collect());
    figure::render(&figure, path).map(|_| ())
}

/// Writes `levels.svg` (log2 variance and log2 |mean| per level), `samples.svg` (N_l per
/// level, one line per eps) and `cost.svg` (eps^2 x cost against eps) into `dir`, and with
/// `--qmc` `mlqmc.svg` (n_l and the variance per randomization per level).
pub fn write_plots(report: &MlmcReport, dir: &Path) -> Result<(), StudyError> {
    let levels = level_panels(report);
    let stem = format!(
        "{} ({}, E[{}])",
        report.scene, report.scheme, report.observable
    );
    draw(&dir.join("levels.svg"), &format!("{stem}: levels"), &levels)?;
    draw(
        &dir.join("samples.svg"),
        &format!("{stem}: N_l"),
        &[samples_panel(report)],
    )?;
    draw(
        &dir.join("cost.svg"),
        &format!("{stem}: cost"),
        &[cost_panel(report)],
    )?;
    match &report.qmc {
        Some(qmc) => draw_quasi(qmc, dir, &stem),
        None => Ok(()),
    }
}

/// The panels of `levels.svg`: log2 of the variance and of |mean| per level of the
/// convergence test, of P_l - P_l-1 and of P_l.
fn level_panels(report: &MlmcReport) -> [Panel; 2] {
    let per_level = |pick: fn(&sdae_mlmc::LevelStats) -> f64, from: u32| {
        report
            .test
            .iter()
            .filter(|l| l.level >= from)
            .map(|l| (f64::from(l.level), pick(l).abs().log2()))
            .collect::<Vec<_>>()
    };
    let level_axes = (plain as Format, plain as Format);
    [
        Panel {
            title: "variance".into(),
            axes: ("level l", "log2 variance"),
            formats: level_axes,
            lines: vec![
                ("P_l - P_l-1".into(), per_level(|l| l.var_y, 1)),
                ("P_l".into(), per_level(|l| l.var_p, 0)),
            ],
        },
        Panel {
            title: "mean".into(),
            axes: ("level l", "log2 |mean|"),
            formats: level_axes,
            lines: vec![
                ("P_l - P_l-1".into(), per_level(|l| l.mean_y, 1)),
                ("P_l".into(), per_level(|l| l.mean_p, 0)),
            ],
        },
    ]
}

/// The panel of `samples.svg`: log10 N_l per level, one line per eps.
fn samples_panel(report: &MlmcReport) -> Panel {
    Panel {
        title: "samples per level".into(),
        axes: ("level l", "N_l"),
        formats: (plain, power_of_ten),
        lines: report
            .complexity
            .iter()
            .map(|row| {
                (
                    format!("eps = {:.0e}", row.run.eps),
                    row.samples
                        .iter()
                        .enumerate()
                        .map(|(l, &n)| (l as f64, (n as f64).log10()))
                        .collect(),
                )
            })
            .collect(),
    }
}

/// The panel of `cost.svg`: log10 of eps^2 x work against log10 eps, of MLMC, standard MC
/// and, with `--qmc`, MLQMC.
fn cost_panel(report: &MlmcReport) -> Panel {
    let cost = |pick: fn(&super::rows::ComplexityRow) -> f64| {
        report
            .complexity
            .iter()
            .map(|row| {
                let eps = row.run.eps;
                (eps.log10(), (eps * eps * pick(row)).log10())
            })
            .collect::<Vec<_>>()
    };
    Panel {
        title: "eps^2 x work (steps)".into(),
        axes: ("accuracy eps", "eps^2 cost"),
        formats: (power_of_ten, power_of_ten),
        lines: vec![
            ("MLMC".into(), cost(|r| r.mlmc_work)),
            ("standard MC".into(), cost(|r| r.standard_work)),
        ]
        .into_iter()
        .chain(report.qmc.as_ref().map(|qmc| {
            let line = qmc.runs.iter().map(|row| {
                let eps = row.run.eps;
                (eps.log10(), (eps * eps * row.run.work).log10())
            });
            ("MLQMC".to_string(), line.collect())
        }))
        .collect(),
    }
}

/// Writes `mlqmc.svg`: the points n_l per level and log2 of the variance per randomization
/// R V_l per level, one line per eps of the MLQMC runs.
fn draw_quasi(qmc: &super::quasi::QmcReport, dir: &Path, stem: &str) -> Result<(), StudyError> {
    let per_level = |pick: fn(&sdae_mlmc::qmc::QuasiLevel) -> f64| {
        qmc.runs
            .iter()
            .map(|row| {
                let line = row.run.levels.iter().map(|q| (f64::from(q.level), pick(q)));
                (format!("eps = {:.0e}", row.run.eps), line.collect())
            })
            .collect::<Vec<_>>()
    };
    let panels = [
        Panel {
            title: "points per randomization".into(),
            axes: ("level l", "n_l"),
            formats: (plain, power_of_ten),
            lines: per_level(|q| (q.points as f64).log10()),
        },
        Panel {
            title: "variance per randomization".into(),
            axes: ("level l", "log2 R V_l"),
            formats: (plain, plain),
            lines: per_level(|q| q.variance_per_randomization.log2()),
        },
    ];
    draw(&dir.join("mlqmc.svg"), &format!("{stem}: MLQMC"), &panels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_are_finite_and_bounded_whatever_the_values() {
        let r = range([1e308, f64::INFINITY, f64::NAN, 3.0, 1.0].into_iter());
        assert!(r.start < 1.0 && r.end > 3.0 && r.end < 10.0, "{r:?}");
        assert_eq!(range([f64::INFINITY, 1e300].into_iter()), 0.0..1.0);
        // The logarithms of any positive finite float are drawn.
        assert!(drawable((0.0, f64::MAX.log2())) && drawable((0.0, 5e-324f64.log2())));
        assert!(!drawable((0.0, f64::NEG_INFINITY)));
    }
}
