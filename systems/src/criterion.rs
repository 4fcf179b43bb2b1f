//! `fracture_criterion` as the step runs it: the run's criterion
//! (`hydrofrac_core::params::Criterion`) applied to the current state. It only marks faces
//! (`edge_ready`); `split` opens them.
//! - `Strength`: the seed's face test sigma_n >= lambda*T0 on every internal face
//!   ([`crate::fracture::fracture_criterion`], seed (7)), with the tip hand-over where the
//!   scenario asks for it ([`crate::fracture::hand_over`]).
//! - `Toughness`: K_I, K_II at every tip by the interaction integral and growth by the maximum
//!   hoop stress where K_eq >= K_Ic ([`crate::toughness`]); the strength test `initiation` on
//!   the faces away from the tips, one new fracture per neighbourhood and pass.

use crate::flow::FlowPart;
use crate::fracture::{self, FractureState};
use crate::toughness::{TipState, one_per_neighbourhood};
use hydrofrac_core::params::{Criterion, CriterionParams, RunParams};
use hydrofrac_core::scenario::Filling;
use hydrofrac_core::view::SolidView;

/// The pressure on the faces of solid joint `k`, Pa (the tips' crack-face load): in coupled
/// runs its cell's pressure (the quasi-static solve's pressures, or the explicit step's mean,
/// which also carries a filling cell's front under `Filling::FrontInCell`); else the
/// scenario's uniform `fracture.pressure`.
pub fn joint_pressure<'a>(
    flow: Option<&'a FlowPart>,
    p: &'a RunParams,
    quasi_static: bool,
) -> impl Fn(usize) -> f64 + 'a {
    move |k: usize| match flow.and_then(|f| f.coupling.as_ref().map(|c| (f, c))) {
        Some((f, c)) => match c.joint_cell[k] {
            u32::MAX => 0.0,
            cell if quasi_static && p.fluid.filling == Filling::Dry => {
                f.view.pressure[cell as usize]
            }
            cell => c.p_mean[cell as usize],
        },
        None => p.face_pressure.unwrap_or(0.0),
    }
}

/// K_I, K_II and the growth direction at every fracture tip of the state (`crate::toughness`),
/// the faces loaded by [`joint_pressure`]. With `screen_k_ic`, tips whose
/// displacement-correlation estimate is below `DC_SCREEN` times it are passed over
/// (`Tips::measure`).
pub fn measure_tips<'a>(
    v: &SolidView,
    fr: &'a mut FractureState,
    flow: Option<&FlowPart>,
    p: &RunParams,
    quasi_static: bool,
    screen_k_ic: Option<f64>,
) -> &'a [TipState] {
    let pressure = joint_pressure(flow, p, quasi_static);
    fr.tips
        .measure(v, &p.solid, p.e_prime, pressure, screen_k_ic);
    &fr.tips.state
}

/// `fracture_criterion`: mark the faces ready to split under the run's criterion `c`.
/// `quasi_static`: the rock's stresses are the solve's, at this step's end (the explicit
/// scheme's lag a step: they come from the displacements before this step's `integrate`).
pub fn criterion(
    v: &mut SolidView,
    fr: &mut FractureState,
    flow: Option<&FlowPart>,
    p: &RunParams,
    c: CriterionParams,
    quasi_static: bool,
) {
    if let Criterion::Toughness { k_ic, .. } = c.kind {
        measure_tips(v, fr, flow, p, quasi_static, Some(k_ic));
        fr.tips.mark(v, k_ic);
    }
    let toughness = matches!(c.kind, Criterion::Toughness { .. });
    if let Some(strength) = c.kind.strength() {
        let skip = toughness.then_some(&fr.tips.near_tip[..]);
        let mut new = std::mem::take(&mut fr.new_marks);
        fracture::fracture_criterion(
            v,
            strength,
            c.by_elements,
            Some((&mut fr.screen, &p.solid, !quasi_static)),
            skip,
            &mut fr.strength_counts,
            &mut new,
        );
        if let Criterion::Strength {
            tip_handover: true, ..
        } = c.kind
        {
            let n = fracture::hand_over(v, &mut fr.handover, &mut new);
            fr.strength_counts.ready += n;
            fr.handed_over += n;
        }
        // Initiation away from tips: one new fracture per neighbourhood and pass.
        if toughness {
            for k in one_per_neighbourhood(v, &mut new) {
                fr.screen.recheck(k);
            }
        }
        fr.new_marks = new;
    }
    fr.ready_edges = match c.kind {
        Criterion::Strength { .. } => fr.strength_counts.ready,
        Criterion::Toughness { .. } => v.edge_ready.iter().filter(|r| **r).count(),
    };
}
