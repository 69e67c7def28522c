//! The design run's pictures: every fully planned layout's mean of the worst quarter of its
//! axis errors against its median steps (`DIR/front.svg`, `.png`), and the scenario's own layout beside the front's
//! best in 3-D (`DIR/best-layouts.svg`, `.png`).

use crate::figures::{DesignFront, DesignLayouts, FrontPoint, LayoutPanel, MAX_PANELS};
use crate::model::geometry::UnitVec;
use crate::planning::design::layout::{Layout, Own};
use crate::planning::design::objectives::Objectives;

/// A fully planned layout: its name, the layout and its full objectives.
pub(super) type Entry<'a> = (&'a String, &'a (Layout, Objectives));

/// The picture of every fully planned layout, the front's marked (`DIR/front.svg`, `.png`).
pub(super) fn front_picture(entries: &[Entry], front: &[usize], own: Own) -> DesignFront {
    let points = entries
        .iter()
        .enumerate()
        .map(|(k, (id, (l, o)))| FrontPoint {
            name: id.to_string(),
            tail_axis_error_deg: o.tail_axis_error_deg,
            median_steps: o.median_steps,
            coils: l.stator.len(),
            on_front: front.contains(&k),
            own: is_own(l, own),
        })
        .collect();
    DesignFront {
        title: "design: every fully planned layout (filled: the front)".into(),
        points,
    }
}

fn v3(p: &UnitVec) -> [f64; 3] {
    [p.x, p.y, p.z]
}

/// Whether the layout `l` is the scenario's own (its coils and magnets, to rounding).
fn is_own(l: &Layout, own: Own) -> bool {
    same_points(&l.stator, own.stator) && same_points(&l.rotor, own.rotor)
}

/// Whether `a` and `b` hold the same points (to rounding).
fn same_points(a: &[UnitVec], b: &[UnitVec]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(p, q)| (p.into_inner() - q.into_inner()).norm() < 1e-9)
}

/// What a layout scored on the full axes, as a panel's caption.
fn caption(o: &Objectives) -> String {
    format!(
        "axis error worst {:.2}, worst quarter {:.2}, median {:.2} deg; median steps {}",
        o.worst_axis_error_deg, o.tail_axis_error_deg, o.median_axis_error_deg, o.median_steps
    )
}

/// A panel's first line: the layout's name, family and counts.
fn heading(what: &str, l_coils: usize, l_magnets: usize) -> String {
    format!("{what}: {l_coils} coils, {l_magnets} magnets")
}

/// The scenario's own layout (with its full objectives when a fully planned layout is it),
/// then the front's best by the mean of the worst quarter of their axis errors
/// (`DIR/best-layouts.svg`, `.png`).
pub(super) fn best_picture(entries: &[Entry], front: &[usize], own: Own) -> DesignLayouts {
    let mine = entries.iter().find(|(_, (l, _))| is_own(l, own));
    let first = LayoutPanel {
        name: match mine {
            Some((id, _)) => heading(
                &format!("the scenario's ({id})"),
                own.stator.len(),
                own.rotor.len(),
            ),
            None => heading("the scenario's", own.stator.len(), own.rotor.len()),
        },
        caption: match mine {
            Some((_, (_, o))) => caption(o),
            None => "not planned about the full axes".into(),
        },
        coils: own.stator.iter().map(v3).collect(),
        magnets: own.rotor.iter().map(v3).collect(),
    };
    let mut best: Vec<&Entry> = front
        .iter()
        .map(|&k| &entries[k])
        .filter(|(_, (l, _))| !is_own(l, own))
        .collect();
    best.sort_by(|(a, (_, oa)), (b, (_, ob))| {
        oa.tail_axis_error_deg
            .total_cmp(&ob.tail_axis_error_deg)
            .then(a.cmp(b))
    });
    let panels = std::iter::once(first)
        .chain(
            best.iter()
                .take(MAX_PANELS - 1)
                .map(|(id, (l, o))| LayoutPanel {
                    name: heading(
                        &format!("{id} ({})", l.family.name()),
                        l.stator.len(),
                        l.rotor.len(),
                    ),
                    caption: caption(o),
                    coils: l.stator.iter().map(v3).collect(),
                    magnets: l.rotor.iter().map(v3).collect(),
                }),
        )
        .collect();
    DesignLayouts {
        title: "design: the best layouts (+ coil, dot magnet; faded: far side)".into(),
        panels,
    }
}
