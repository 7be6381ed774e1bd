//! The calibration plot: measured v and ω against the fitted gains and the butterfly.

use std::path::Path;

use plotters::prelude::*;

use super::{Calibration, Measurement};

/// A chart of the calibration plot (f64 × f64 axes).
type Panel<'a, 'b> = ChartContext<
    'a,
    SVGBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// One panel of the calibration plot: its chart over ±`x_max` × ±`y_max` with axis labels and
/// the measured points.
fn panel<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    caption: String,
    (x_desc, y_desc): (String, &str),
    (x_max, y_max): (f64, f64),
    points: impl Iterator<Item = (f64, f64)>,
) -> Result<Panel<'a, 'b>, String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let mut c = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 16))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(-x_max..x_max, -y_max..y_max)
        .map_err(|x| e(&x))?;
    c.configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .draw()
        .map_err(|x| e(&x))?;
    c.draw_series(points.map(|p| Circle::new(p, 4, BLUE.filled())))
        .map_err(|x| e(&x))?;
    Ok(c)
}

/// A fitted gain y = k·x drawn across a panel, its ends kept inside the chart (plotters does
/// not clip line ends).
fn gain_line(c: &mut Panel<'_, '_>, k: f64, (x_max, y_max): (f64, f64)) -> Result<(), String> {
    let x = if k.abs() > 0.0 {
        x_max.min(y_max / k.abs())
    } else {
        x_max
    };
    c.draw_series(LineSeries::new(
        [(-x, -k * x), (x, k * x)],
        RED.stroke_width(2),
    ))
    .map_err(|x| x.to_string())?;
    Ok(())
}

/// Plot measured v and ω against the fitted lines of THESIS (3.10) and the butterfly.
pub fn plot_fit(path: &Path, cal: &Calibration) -> Result<(), String> {
    let root = SVGBackend::new(path, (1200, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let panels = root.split_evenly((1, 3));
    let f = cal.fit;
    let unit = cal.plan.mode.unit();
    let ms = &cal.measurements;
    let peak = |x: fn(&Measurement) -> f64, at_least: f64| {
        ms.iter().map(|m| x(m).abs()).fold(at_least, f64::max) * 1.1 + 1e-6
    };
    let vmax = peak(|m| m.v, f.b[0]);
    let wmax = peak(|m| m.omega, f.a[1].abs());
    // v against mean command.
    let range = (f.m_max, vmax);
    let mut c = panel(
        &panels[0],
        format!("v = k_v (M_r+M_l)/2, k_v = {:.3e}", f.k_v),
        (format!("mean command ({unit})"), "v (m/s)"),
        range,
        ms.iter().map(|m| ((m.m_r + m.m_l) / 2.0, m.v)),
    )?;
    gain_line(&mut c, f.k_v, range)?;
    // ω against difference.
    let range = (2.0 * f.m_max, wmax);
    let mut c = panel(
        &panels[1],
        format!("ω = k_ω (M_r−M_l), k_ω = {:.3e}", f.k_omega),
        (format!("command difference ({unit})"), "ω (rad/s)"),
        range,
        ms.iter().map(|m| (m.m_r - m.m_l, m.omega)),
    )?;
    gain_line(&mut c, f.k_omega, range)?;
    // Butterfly.
    let mut c = panel(
        &panels[2],
        format!(
            "butterfly A = ({:.3}, {:.2}), B = ({:.3}, 0)",
            f.a[0], f.a[1], f.b[0]
        ),
        ("v (m/s)".to_string(), "ω (rad/s)"),
        (vmax, wmax),
        ms.iter().map(|m| (m.v, m.omega)),
    )?;
    let (av, aw, bv) = (f.a[0], f.a[1].abs(), f.b[0]);
    for s in [1.0, -1.0] {
        let wing = vec![
            (0.0, 0.0),
            (s * av, -aw),
            (s * bv, 0.0),
            (s * av, aw),
            (0.0, 0.0),
        ];
        c.draw_series(LineSeries::new(wing, RED.stroke_width(2)))
            .map_err(|x| x.to_string())?;
    }
    root.present().map_err(|x| x.to_string())
}
