//! The event catalogue's outputs of `hydrofrac run` (`seismicity:`, `docs/seismicity.md`):
//! `events.csv`, four figures and `summary.json` `seismicity`. The catalogue itself is the
//! `seismicity` system's (`systems/src/seismicity.rs`).

use crate::plot::{Panel, Segment, Series};
use crate::sim::Simulation;
use crate::systems::seismicity::{
    Catalogue, Event, MAGNITUDE_BIN, MIN_B_EVENTS, b_value, completeness_max_curvature,
};
use serde_json::json;
use std::fmt::Write as _;

/// Columns of `events.csv` (SI: s, m, m/s, Pa, N (N m per m), N m).
pub const COLUMNS: &str = "id,t_start,t_end,hypocentre_x,hypocentre_y,centroid_x,centroid_y,\
joints,length,mean_slip,max_slip,peak_rate,stress_drop,moment_per_thickness,width,moment,\
magnitude,injected_volume,open_at_end";

/// `events.csv`'s text: the header, then one row per event in the order they closed. `None`
/// if a value is not finite (the catalogue is then not written: no `inf` or `NaN` token in a
/// result).
pub fn events_csv(events: &[Event]) -> Option<String> {
    let mut s = String::with_capacity(200 * (events.len() + 1));
    s.push_str(COLUMNS);
    s.push('\n');
    for e in events {
        let nums = [
            e.t_start,
            e.t_end,
            e.hypocentre[0],
            e.hypocentre[1],
            e.centroid[0],
            e.centroid[1],
            e.length,
            e.mean_slip,
            e.max_slip,
            e.peak_rate,
            e.stress_drop,
            e.moment_per_thickness,
            e.width,
            e.moment,
            e.magnitude,
            e.injected,
        ];
        if nums.iter().any(|x| !x.is_finite()) {
            return None;
        }
        let [
            t0,
            t1,
            hx,
            hy,
            cx,
            cy,
            len,
            mean,
            max,
            rate,
            drop,
            m0p,
            w,
            m0,
            mw,
            inj,
        ] = nums;
        let _ = writeln!(
            s,
            "{},{t0},{t1},{hx},{hy},{cx},{cy},{},{len},{mean},{max},{rate},{drop},{m0p},{w},{m0},\
             {mw},{inj},{}",
            e.id,
            e.joints,
            u8::from(e.open_at_end)
        );
    }
    Some(s)
}

/// The b-value of the catalogue's magnitudes at the completeness `completeness` (`None`: by
/// maximum curvature); `None` with fewer than [`MIN_B_EVENTS`] events above it.
pub fn catalogue_b(magnitudes: &[f64], completeness: Option<f64>) -> Option<BValue> {
    let (mc, from) = match completeness {
        Some(m) => (m, "scenario"),
        None => (
            completeness_max_curvature(magnitudes, MAGNITUDE_BIN)?,
            "maximum curvature",
        ),
    };
    let (b, error, events) = b_value(magnitudes, mc, MAGNITUDE_BIN, MIN_B_EVENTS)?;
    Some(BValue {
        b,
        error,
        events,
        completeness: mc,
        from,
    })
}

/// An Aki-Utsu b-value estimate ([`b_value`]).
#[derive(Clone, Copy, Debug)]
pub struct BValue {
    pub b: f64,
    pub error: f64,
    pub events: usize,
    pub completeness: f64,
    pub from: &'static str,
}

/// Write the catalogue's outputs into the run's folder (if it has one) and return
/// `summary.json`'s `seismicity`. A file or figure that cannot be written is a warning.
pub fn outputs(sim: &mut Simulation, warnings: &mut Vec<String>) -> Option<serde_json::Value> {
    sim.close_catalogue();
    let sim = &*sim;
    let cat = sim.catalogue()?;
    let completeness = sim
        .params()
        .seismicity
        .as_ref()
        .and_then(|s| s.completeness);
    let g = cat.settings.shear_modulus;
    let mags: Vec<f64> = cat.events.iter().map(|e| e.magnitude).collect();
    let largest = cat
        .events
        .iter()
        .max_by(|a, b| a.moment.total_cmp(&b.moment));
    let injected = crate::systems::seismicity::injection(sim.flow()).injected;
    let b = catalogue_b(&mags, completeness);
    let mut s = json!({
        "events": cat.events.len(),
        "open_at_end": cat.events.iter().filter(|e| e.open_at_end).count(),
        "v_start": cat.settings.v_start,
        "v_stop": cat.settings.v_stop,
        "width": cat.settings.width.map_or(json!("ruptured length"), |w| json!(w)),
        "cumulative_moment_per_thickness": cat.cumulative_moment,
        "injected_volume": injected,
        "mcgarr_bound_per_thickness": g * injected,
    });
    if let Some(e) = largest {
        s["largest_magnitude"] = json!(e.magnitude);
        s["largest_moment"] = json!(e.moment);
        s["largest_event"] = json!(e.id);
    }
    if let Some(b) = b {
        s["b_value"] = json!({
            "b": b.b, "error": b.error, "events": b.events, "completeness": b.completeness,
            "completeness_from": b.from, "bin": MAGNITUDE_BIN,
        });
    }
    if let Some(o) = sim.output() {
        let write = |name: &str, text: &str| -> std::io::Result<()> {
            crate::atomic::write(&o.claim(name)?, text.as_bytes())
        };
        match events_csv(&cat.events) {
            Some(text) => {
                if let Err(e) = write("events.csv", &text) {
                    warnings.push(format!("events.csv not written: {e}"));
                }
            }
            None => warnings.push("events.csv not written: a non-finite value".into()),
        }
        if let Err(e) = figures(sim, cat, b) {
            warnings.push(format!("seismicity figures not written: {e}"));
        }
    }
    Some(s)
}

/// The four figures: the event map, magnitudes against time with the injection pressure,
/// Gutenberg-Richter with the b-value fit, cumulative moment against injected volume with
/// McGarr's bound (the last two only with events or injection to show).
fn figures(sim: &Simulation, cat: &Catalogue, b: Option<BValue>) -> anyhow::Result<()> {
    let o = sim.output().expect("output folder");
    let name = &sim.params().name;
    let v = sim.solid();
    let fractures: Vec<Segment> = v
        .joint_nodes
        .iter()
        .map(|n| Segment {
            a: v.x0[n[0] as usize],
            b: v.x0[n[1] as usize],
        })
        .collect();
    let ev = &cat.events;
    let centres: Vec<[f64; 2]> = ev.iter().map(|e| e.centroid).collect();
    let times: Vec<f64> = ev.iter().map(|e| e.t_start).collect();
    let (lo, hi) = ev.iter().fold((f64::MAX, f64::MIN), |(a, b), e| {
        (a.min(e.magnitude), b.max(e.magnitude))
    });
    let radius: Vec<f64> = ev
        .iter()
        .map(|e| {
            4.0 + 26.0
                * if hi > lo {
                    (e.magnitude - lo) / (hi - lo)
                } else {
                    0.5
                }
        })
        .collect();
    let title = format!(
        "{name}: {} events (centroids; disc size: Mw {:.2} to {:.2})",
        ev.len(),
        if ev.is_empty() { 0.0 } else { lo },
        if ev.is_empty() { 0.0 } else { hi }
    );
    crate::plot::event_map(
        &o.claim("events_map.png")?,
        &title,
        &fractures,
        &centres,
        &radius,
        &times,
        "onset time [s]",
    )?;

    let mut panels = vec![Panel {
        title: format!("{name}: event magnitudes"),
        xlabel: "onset time [s]".into(),
        ylabel: "Mw".into(),
        series: vec![Series {
            label: String::new(),
            points: ev.iter().map(|e| (e.t_start, e.magnitude)).collect(),
        }],
        points: true,
    }];
    let injecting = cat.history.iter().any(|h| h.injected > 0.0);
    if injecting {
        panels.push(Panel {
            title: "injection pressure".into(),
            xlabel: "time [s]".into(),
            ylabel: "pressure [MPa]".into(),
            series: vec![Series {
                label: String::new(),
                points: cat
                    .history
                    .iter()
                    .map(|h| (h.time, h.pressure / 1e6))
                    .collect(),
            }],
            points: false,
        });
    }
    crate::plot::stacked(&o.claim("events_magnitude.png")?, &panels)?;

    // Gutenberg-Richter: log10 of the number of events at or above each bin.
    let mut mags: Vec<f64> = ev.iter().map(|e| e.magnitude).collect();
    mags.sort_by(f64::total_cmp);
    let mut gr = Vec::new();
    if let (Some(&first), Some(&last)) = (mags.first(), mags.last()) {
        let (k0, k1) = (
            (first / MAGNITUDE_BIN).round() as i64,
            (last / MAGNITUDE_BIN).round() as i64,
        );
        for k in k0..=k1.min(k0 + 400) {
            let m = k as f64 * MAGNITUDE_BIN;
            let n = mags
                .iter()
                .filter(|&&x| (x / MAGNITUDE_BIN).round() as i64 >= k)
                .count();
            if n > 0 {
                gr.push((m, (n as f64).log10()));
            }
        }
    }
    let mut series = vec![Series {
        label: "catalogue: log10 N(>= Mw)".into(),
        points: gr.clone(),
    }];
    if let Some(b) = b {
        let n_mc = b.events as f64;
        let top = mags.last().copied().unwrap_or(b.completeness);
        series.push(Series {
            label: format!(
                "Aki-Utsu b = {:.2} +/- {:.2} (Mc = {:.1}, {}, {} events)",
                b.b, b.error, b.completeness, b.from, b.events
            ),
            points: vec![
                (b.completeness, n_mc.log10()),
                (top, n_mc.log10() - b.b * (top - b.completeness)),
            ],
        });
    }
    crate::plot::lines(
        &o.claim("events_gutenberg_richter.png")?,
        &format!("{name}: frequency-magnitude"),
        "Mw",
        "log10 N(>= Mw)",
        &series,
    )?;

    if injecting {
        let g = cat.settings.shear_modulus;
        let hist: Vec<(f64, f64)> = cat
            .history
            .iter()
            .map(|h| (h.injected, h.cumulative_moment))
            .collect();
        let bound: Vec<(f64, f64)> = hist.iter().map(|&(v, _)| (v, g * v)).collect();
        crate::plot::loglog(
            &o.claim("events_moment.png")?,
            &format!("{name}: cumulative moment against injected volume"),
            "injected volume [m^2 per m]",
            "cumulative M0' [N m per m]",
            &[
                Series {
                    label: "catalogue (running events included)".into(),
                    points: hist,
                },
                Series {
                    label: "McGarr bound G dV".into(),
                    points: bound,
                },
            ],
        )?;
    }
    Ok(())
}
