//! SVG picture of an assembly coloured by connection load (top view, or side view when the
//! assembly is taller than it is deep).

use crate::gate::Report;
use crate::model::Assembly;
use plotters::prelude::*;
use std::path::Path;

/// Colour from green (0) through yellow to red (≥ 1).
fn load_colour(u: f64) -> RGBColor {
    let u = u.clamp(0.0, 1.0);
    if u < 0.5 {
        RGBColor((510.0 * u) as u8, 180, 40)
    } else {
        RGBColor(230, (180.0 * (2.0 - 2.0 * u)) as u8, 40)
    }
}

/// Draw `a` with the loads of `r` into an SVG file.
pub fn draw(a: &Assembly, r: &Report, path: &Path) -> Result<(), String> {
    let res = a.resolve().map_err(|e| e.to_string())?;
    if res.com.is_empty() {
        return Err("no modules to draw".into());
    }
    let span = |k: usize| {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in res
            .com
            .iter()
            .chain(res.connections.iter().map(|c| &c.point))
            .chain(res.contacts.iter().map(|c| &c.point))
        {
            lo = lo.min(p[k]);
            hi = hi.max(p[k]);
        }
        (lo, hi)
    };
    let (ylo, yhi) = span(1);
    let (zlo, zhi) = span(2);
    let side = zhi - zlo > yhi - ylo;
    let v = if side { 2 } else { 1 };
    let (xlo, xhi) = span(0);
    let (vlo, vhi) = span(v);
    let pad = 0.05 * ((xhi - xlo).max(vhi - vlo)).max(0.01);
    let root = SVGBackend::new(path, (900, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let title = format!(
        "{} — margin {}",
        r.verdict.name(),
        r.margin.map_or("none".into(), |m| format!("{m:.4}"))
    );
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d((xlo - pad)..(xhi + pad), (vlo - pad)..(vhi + pad))
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("x (m)")
        .y_desc(if side { "z (m)" } else { "y (m)" })
        .draw()
        .map_err(|e| e.to_string())?;
    let pt = |p: &[f64; 3]| (p[0], p[v]);
    let wmax = r.max_strength.unwrap_or(0.0).max(1e-12);
    for (k, c) in res.connections.iter().enumerate() {
        let (u, over) = r
            .connections
            .get(k)
            .map(|cr| (cr.use_of_limit.unwrap_or(cr.strength / wmax), cr.over_limit))
            .unwrap_or((0.0, false));
        let col = if r.connections.is_empty() {
            RGBColor(120, 120, 120)
        } else {
            load_colour(u)
        };
        let style = ShapeStyle::from(&col).stroke_width(if over { 5 } else { 3 });
        for m in [c.child, c.parent] {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![pt(&res.com[m]), pt(&c.point)],
                    style,
                )))
                .map_err(|e| e.to_string())?;
        }
    }
    chart
        .draw_series(res.com.iter().zip(&res.fixed).map(|(p, f)| {
            let col = if *f { BLACK } else { RGBColor(90, 90, 200) };
            Circle::new(pt(p), 4, col.filled())
        }))
        .map_err(|e| e.to_string())?;
    chart
        .draw_series(
            res.contacts
                .iter()
                .map(|c| Cross::new(pt(&c.point), 3, RGBColor(100, 100, 100))),
        )
        .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())?;
    Ok(())
}
