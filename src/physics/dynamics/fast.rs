//! The fast settle: Bogacki-Shampine 3(2) while the motion is nonlinear, watching the pairs'
//! cut-offs (the graze watch: cut-off events where the model offers them, `events`, else grazes
//! and crossings) and looking for the linear end phase, with a tight approach to a graze and a
//! tight fallback where the loose tolerance cannot be trusted.

use super::end_phase::{EndPhase, EndSearch};
use super::events::{self, Seen, Sides, MAX_REDOS};
use super::reference::{dopri5_run, settle_dopri5};
use super::{finish, hermite_weights, RotorDynamics, SettleParams, SettleResult, State, Stop};
use crate::physics::integrator::{integrate_until, End, Outcome, Tolerances, Verdict};
use crate::physics::torque::{bits_of, first_bits, rotation_matrix, SideMask, TorqueModel};
use nalgebra::Vector3;

/// The fast path's stiffness scale (isotropic bodies of models that have one: the linear
/// regime and its Newton finish are then available) and its relative tolerance, tighter for
/// light damping.
fn fast_tolerance<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    params: &SettleParams,
) -> (Option<f64>, f64) {
    let i = sys.body.inertia;
    let isotropic = (i.x - i.y).abs() <= 1e-12 * i.x && (i.x - i.z).abs() <= 1e-12 * i.x;
    let scale = sys.model.stiffness_scale().filter(|_| isotropic);
    let rtol = match scale {
        Some(k1) => {
            let zeta = damping_ratio(sys, k1);
            params
                .rtol
                .min(NONLINEAR_RTOL)
                .min((NONLINEAR_RTOL_PER_ZETA2 * zeta * zeta).max(NONLINEAR_RTOL_FLOOR))
        }
        None => params.rtol,
    };
    (scale, rtol)
}

/// The damping ratio of one aligned pair of stiffness `k1` on the (isotropic) body.
fn damping_ratio<M: TorqueModel>(sys: &RotorDynamics<'_, M>, k1: f64) -> f64 {
    sys.body.damping / (2.0 * (k1 * sys.body.inertia.x).sqrt())
}

/// A trace to append the accepted steps to, and its length before the run at hand (a run given
/// up for a tight one gives up its steps too).
type Tail<'t> = (Option<&'t mut Vec<(f64, State)>>, usize);

/// What the fast path's integration `out` (ended without the Newton finish) says: the ball
/// where the stepper left it and why it stopped; never settled without damping; a stop near
/// rest but never near a strict minimum (`tight`: where the model has a linear regime, the
/// tolerances to settle such a set again at) is re-integrated tightly, or reported unheld when
/// the set need not be followed.
fn conclude<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    out: &Outcome<7>,
    evaluations: u32,
    tight: Option<(f64, f64)>,
    tail: Tail<'_>,
) -> SettleResult {
    // where the stepper left the ball, and why it says it stopped
    let stopped_here = |stop: Stop| {
        finish(
            sys.model,
            sys.active,
            &out.y,
            out.t,
            evaluations,
            out.steps,
            stop,
        )
    };
    if sys.body.damping <= 0.0 {
        // Undamped, the ball never settles (it was not at rest in equilibrium at the start):
        // whatever the stepper's own dissipation did, the physics says no.
        return stopped_here(match out.end {
            End::Stopped => Stop::TimeLimit,
            e => e.into(),
        });
    }
    let near_rest = |y: &[f64; 7]| {
        Vector3::new(y[4], y[5], y[6]).norm() < NEAR_REST * params.omega_tol
            && sys.body_torque(y).norm() < NEAR_REST * params.torque_tol
    };
    let unsure = match out.end {
        End::Stopped => true,
        End::TimeLimit => near_rest(&out.y),
        _ => false,
    };
    if let Some(tol) = tight.filter(|_| unsure) {
        // settled (or nearly at rest at t_max), but never near a strict minimum: not sure where
        // along the free direction the ball stops, nor when
        if !params.follow_unheld {
            return stopped_here(Stop::Unheld);
        }
        return settle_tight(sys, y0, params, evaluations, tail, tol);
    }
    stopped_here(out.end.into())
}

/// The fast path: Bogacki-Shampine 3(2) at the scenario's (loose) tolerances while the motion
/// is nonlinear, then, once the ball moves within [`LINEAR_RADIUS`](super::end_phase::LINEAR_RADIUS) of a strict minimum (found
/// by Newton on the torque, positive-definite stiffness, no magnet near its well's cut-off), the
/// linear damped motion about that minimum solved in closed form, mode by mode, for the first
/// instant it meets the settle test. Integrating that creep step by step is what an explicit
/// stepper does worst: it runs at its stability limit there, where its own (anti-)damping, not
/// the physics', decides when the test passes.
///
/// If the nonlinear phase ends (the settle test passes, or t_max) without a strict minimum (a
/// direction that nothing holds: a pair out of reach, a neutral rotation about a lone pair's
/// axis), where the ball stops along that direction depends on how accurately the whole coast
/// was integrated, which a loose tolerance cannot promise (at its stability limit the stepper
/// neither damps nor stops the free rotation): the settle is run again at tight tolerances.
pub(super) fn settle_fast<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    trace: Option<&mut Vec<(f64, State)>>,
) -> SettleResult {
    settle_fast_from(sys, y0, params, trace, (TIGHT_APPROACHES, None))
}

/// [`settle_fast`] from the state `y0` (at rest, or moving where a tight approach handed over),
/// its times from there; after `approaches` tight approaches to grazes the next graze sends it
/// to the tight fallback; `carried`: the pairs' sides at `y0` where a settle goes on beyond a
/// skin (else every pair within reach there is within).
fn settle_fast_from<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    trace: Option<&mut Vec<(f64, State)>>,
    (approaches, carried): (u32, Option<SideMask>),
) -> SettleResult {
    let (scale, rtol) = fast_tolerance(sys, &params);
    let tol = Tolerances {
        rtol,
        atol: params.atol,
    };
    // a tenth of the time scale sqrt(I / K) of the active pairs together
    let first_step = scale.map_or(0.0, |k1| {
        FIRST_STEP * (sys.body.inertia.x / (k1 * sys.active.len().max(1) as f64)).sqrt()
    });
    let watch = GrazeWatch::new(sys, y0, scale.is_some());
    let sides = Sides::new(sys, watch.on.then_some(watch.before.as_slice()), carried);
    // where the watch cannot follow the margins, the approach may have crossed a cut-off
    let trusted = watch.on && sys.model.trusts_uncrossed_cutoffs();
    let traced = trace.as_deref().map_or(0, |tr| tr.len());
    let mut at = Watchers {
        watch,
        search: scale.map(|k1| EndSearch::new(k1, !trusted, params.t_max)),
        grazed: None,
        left: false,
        last: (0.0, y0),
        trace,
    };
    let out = integrate_until(&sides, y0, params.t_max, tol, first_step, |t, y, dy| {
        at.verdict(&sides, &params, t, y, dy)
    });
    // a minimum near a cut-off the approach may have crossed is settled again as a graze is; a
    // set no strict minimum holds, at its own tolerance
    let near_cutoff = at.search.as_ref().is_some_and(|s| s.near_cutoff);
    let tight = scale.map(|k1| {
        if near_cutoff {
            FALLBACK_TOL
        } else {
            unheld_tolerance(sys, k1)
        }
    });
    let (newton_evals, end) = at.search.map_or((0, None), |s| (s.evaluations, s.found));
    let evaluations = out.evaluations + newton_evals;
    if let Some(e) = end {
        return end_phase_result(sys, &e, params, evaluations, out.steps, at.trace);
    }
    if at.left {
        let spent = (evaluations, out.steps, traced);
        let within = sides.within.get();
        return go_on_beyond(
            sys,
            y0,
            params,
            spent,
            (at.last, within),
            at.trace,
            approaches,
        );
    }
    match at.grazed {
        // where the ball goes from a graze hangs on errors this tolerance allows: with cut-off
        // events the approach to it is integrated again tightly, without them the whole settle
        Some(t_past) if approaches > 0 && sides.events => {
            let spent = (evaluations, out.steps, traced);
            return approach_tightly(sys, y0, params, t_past, spent, at.trace, approaches);
        }
        Some(_) => {
            let tail = (at.trace, traced);
            return settle_tight(sys, y0, params, evaluations, tail, FALLBACK_TOL);
        }
        None => {}
    }
    let tail = (at.trace, traced);
    conclude(sys, y0, params, &out, evaluations, tight, tail)
}

/// What the fast path watches at each accepted step: the graze watch (or the cut-off events),
/// the search for the end phase, and the trace.
struct Watchers<'t> {
    watch: GrazeWatch,
    search: Option<EndSearch>,
    /// Where a graze was seen: a time past it (the end of its step plus the step's length).
    grazed: Option<f64>,
    /// Whether the watch went off with cut-off events (a "coils" model beyond its skin).
    left: bool,
    /// The last accepted step kept: its end (t, y).
    last: (f64, [f64; 7]),
    trace: Option<&'t mut Vec<(f64, State)>>,
}

impl Watchers<'_> {
    /// The integration's verdict on the accepted step ending at (t, y), rate dy.
    fn verdict<M: TorqueModel>(
        &mut self,
        sides: &Sides<'_, '_, M>,
        params: &SettleParams,
        t: f64,
        y: &[f64; 7],
        dy: &[f64; 7],
    ) -> Verdict {
        let sys = sides.sys;
        let events = self.watch.on && sides.events;
        if events {
            let step = t - self.watch.t_before;
            match self.watch.look(sides, t, y) {
                Look::Redo(h) => return Verdict::Redo(h),
                Look::Changed => {
                    // a pair switched sides here: the rate is evaluated again, the tests wait
                    self.push(t, y);
                    return Verdict::Changed;
                }
                Look::Grazed => {
                    self.grazed = Some(t + step);
                    return Verdict::Stop;
                }
                // the watch went off (a "coils" model beyond its skin): the settle goes on from
                // the last step within it, on lists built there (`go_on_beyond`)
                Look::Crossed => {
                    self.left = true;
                    return Verdict::Stop;
                }
                Look::Quiet => {}
            }
        }
        self.push(t, y);
        if sys.settled(params, y, dy) {
            return Verdict::Stop;
        }
        if self.watch.on && !events {
            match self.watch.look(sides, t, y) {
                Look::Grazed => {
                    self.grazed = Some(t);
                    return Verdict::Stop;
                }
                Look::Crossed => self.crossed(),
                _ => {}
            }
        }
        Verdict::from(self.search.as_mut().is_some_and(|s| s.stops(sys, t, y, dy)))
    }

    /// The approach may have crossed a cut-off: the end phase's search no longer trusts a
    /// minimum near one.
    fn crossed(&mut self) {
        if let Some(s) = self.search.as_mut() {
            s.crossed = true;
        }
    }

    fn push(&mut self, t: f64, y: &[f64; 7]) {
        self.last = (t, *y);
        if let Some(tr) = self.trace.as_deref_mut() {
            tr.push((t, State::from_column_slice(y)));
        }
    }
}

/// A graze seen by the fast path: where the ball goes from it hangs on errors the loose
/// tolerance allows, so the approach to it, from `y0` to `t_past` (past the graze), is
/// integrated again at the tight fallback's tolerances, and the fast path goes on from there
/// (with one tight approach fewer left): the rest of the settle, its crossings, its end phase,
/// at the loose tolerance. `spent`: the evaluations and steps of the loose run given up, and
/// the length of the trace before it.
fn approach_tightly<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    t_past: f64,
    spent: (u32, u32, usize),
    mut trace: Option<&mut Vec<(f64, State)>>,
    approaches: u32,
) -> SettleResult {
    let t_h = t_past.min(params.t_max);
    let tight = SettleParams {
        rtol: FALLBACK_RTOL,
        atol: FALLBACK_ATOL,
        t_max: t_h,
        ..params
    };
    if let Some(tr) = trace.as_deref_mut() {
        // the loose run's steps are given up with it
        tr.truncate(spent.2);
    }
    let (mut r, y_h) = dopri5_run(sys, y0, tight, trace.as_deref_mut());
    r.evaluations = r.evaluations.saturating_add(spent.0);
    r.steps = r.steps.saturating_add(spent.1);
    if r.stop != Stop::TimeLimit || t_h >= params.t_max {
        return r;
    }
    let spent = (r.evaluations, r.steps);
    handed_over((t_h, params), spent, trace, |rest, tr| {
        settle_fast_from(sys, y_h, rest, tr, (approaches - 1, None))
    })
}

/// The settle (with `params`) that goes on from a handover at t_h (`spent`: the evaluations
/// and steps before it) by `go_on`, run on the rest of the time (`params` with t_max less t_h)
/// with its trace appended: its times, the trace's included, counted from the settle's start,
/// its work added to what was spent.
fn handed_over(
    (t_h, params): (f64, SettleParams),
    spent: (u32, u32),
    mut trace: Option<&mut Vec<(f64, State)>>,
    go_on: impl FnOnce(SettleParams, Option<&mut Vec<(f64, State)>>) -> SettleResult,
) -> SettleResult {
    let rest = SettleParams {
        t_max: params.t_max - t_h,
        ..params
    };
    let from = trace.as_deref().map_or(0, |tr| tr.len());
    let mut after = go_on(rest, trace.as_deref_mut());
    if let Some(tr) = trace {
        tr[from..].iter_mut().for_each(|(t, _)| *t += t_h);
    }
    after.settle_time_s += t_h;
    after.arrival_time_s += t_h;
    after.evaluations = after.evaluations.saturating_add(spent.0);
    after.steps = after.steps.saturating_add(spent.1);
    after
}

/// A settle with cut-off events whose ball went beyond the skin of its lists (the model
/// offers no margins there) after the accepted step `last` = (t_h, y_h), with the pairs on the
/// sides `within` there: it goes on by the fast path from there, on lists built at y_h with the
/// sides carried over ([`TorqueModel::continued_at`]), its times, evaluations, steps and trace
/// continued (`spent`: those of the run so far, and the trace's length before it); where it
/// cannot, or the damping is light (below [`GO_ON_ZETA`]), it is settled again from the start
/// `y0` at the tight fallback's tolerances.
fn go_on_beyond<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    spent: (u32, u32, usize),
    ((t_h, y_h), within): ((f64, [f64; 7]), SideMask),
    trace: Option<&mut Vec<(f64, State)>>,
    approaches: u32,
) -> SettleResult {
    let r = rotation_matrix(y_h[0], y_h[1], y_h[2], y_h[3]);
    let damped = sys
        .model
        .stiffness_scale()
        .is_some_and(|k1| damping_ratio(sys, k1) >= GO_ON_ZETA);
    let next = (damped && t_h < params.t_max)
        .then(|| sys.model.continued_at(&r, sys.active, within))
        .flatten();
    let Some((lists, carried)) = next else {
        return settle_tight(sys, y0, params, spent.0, (trace, spent.2), FALLBACK_TOL);
    };
    let beyond = RotorDynamics::new(&lists, sys.active, sys.body);
    handed_over((t_h, params), (spent.0, spent.1), trace, |rest, tr| {
        settle_fast_from(&beyond, y_h, rest, tr, (approaches, Some(carried)))
    })
}

/// The settle that ends in the end phase `e`, found after `evaluations` and `steps`: its
/// closed-form first instant of the settle test (or t_max), traced when a trace is kept.
fn end_phase_result<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    e: &EndPhase,
    params: SettleParams,
    evaluations: u32,
    steps: u32,
    trace: Option<&mut Vec<(f64, State)>>,
) -> SettleResult {
    let (t, y, settled) = e.solve(sys.body, &params);
    if let Some(tr) = trace {
        tr.push((t, State::from_column_slice(&y)));
    }
    let stop = if settled {
        Stop::Settled
    } else {
        Stop::TimeLimit
    };
    SettleResult {
        arrival_time_s: e.arrival(sys.body, &params, t),
        ..finish(sys.model, sys.active, &y, t, evaluations, steps, stop)
    }
}

/// The graze watch: each pair's cut-off margin and its rate at the last accepted step looked
/// at, and now. A margin changes no faster than |w| (|d(p . s)/dt| <= |w|), so until the ball
/// has turned, since a pair's margin was last computed, as far as that margin was from the
/// cut-off (less [`GRAZE_EPS`], with |w| taken at twice the larger of a step's ends), the pair
/// cannot have come near its cut-off and its margin is not computed again: a step computes the
/// margins of the pairs that may be near their cut-off only (every pair where there are more
/// than a [`SideMask`] has bits, and while landing on an event), and the others can neither
/// cross, graze nor turn back, so the watch decides as it would on every margin.
struct GrazeWatch {
    /// Whether the watch is on: the model offers margins (a "coils" model beyond its skin
    /// does not), and the path has a linear regime.
    on: bool,
    /// Whether the pairs' margins are followed one by one (at most [`SideMask::BITS`] pairs).
    by_pair: bool,
    before: Vec<(f64, f64)>,
    now: Vec<(f64, f64)>,
    /// Each pair's `turned` at which its margin must be computed again (followed one by one),
    /// and the least of them: no margin is computed before the ball has turned this far.
    due_at: Vec<f64>,
    slack: f64,
    y_before: [f64; 7],
    t_before: f64,
    w_before: f64,
    /// How far the ball may have turned since the watch began (twice |w| over each step).
    turned: f64,
    /// The pairs whose margins in `now` are those at `y_before` (the last step computed them).
    fresh: SideMask,
    /// Landings tried for the event at hand, and whether the next step must be looked at
    /// (it is one).
    redos: u32,
    landing: bool,
}

/// What the graze watch saw at a step.
enum Look {
    /// Nothing near a cut-off.
    Quiet,
    /// A margin changed sign, or the watch can no longer follow the margins: the approach may
    /// have crossed a cut-off.
    Crossed,
    /// A pair grazed its cut-off ([`grazes`]).
    Grazed,
    /// A pair leaves its side of its cut-off within the step (cut-off events): take the step
    /// again, this long, to land there.
    Redo(f64),
    /// Pairs were switched to the other side of their cut-off where the step ends.
    Changed,
}

/// The least |margin| of `m`.
fn least(m: &[(f64, f64)]) -> f64 {
    m.iter().fold(f64::INFINITY, |a, &(x, _)| a.min(x.abs()))
}

/// The cut-off margins of the active pairs at the state `y` into `out`; false where the model
/// offers none.
fn margins<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y: &[f64; 7],
    out: &mut Vec<(f64, f64)>,
) -> bool {
    out.clear();
    let r = rotation_matrix(y[0], y[1], y[2], y[3]);
    let w = Vector3::new(y[4], y[5], y[6]);
    sys.model.cutoff_margins(&r, &w, sys.active, out)
}

/// The cut-off margins at the state `y` of the pairs of `pairs` into their places in `out`
/// (`by_pair`), or of every pair ([`margins`]); false where the model offers none.
fn margins_of<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y: &[f64; 7],
    by_pair: bool,
    pairs: SideMask,
    out: &mut Vec<(f64, f64)>,
) -> bool {
    if !by_pair {
        return margins(sys, y, out);
    }
    let r = rotation_matrix(y[0], y[1], y[2], y[3]);
    let w = Vector3::new(y[4], y[5], y[6]);
    sys.model.cutoff_margins_of(&r, &w, sys.active, pairs, out)
}

impl GrazeWatch {
    /// The watch from the start `y0` (at rest), on when `linear` (the path has a linear
    /// regime) and the model offers margins there.
    fn new<M: TorqueModel>(sys: &RotorDynamics<'_, M>, y0: [f64; 7], linear: bool) -> Self {
        let mut before = Vec::new();
        let on = linear && margins(sys, &y0, &mut before);
        let by_pair = before.len() <= SideMask::BITS as usize;
        let due_at: Vec<f64> = before.iter().map(|&(m, _)| m.abs() - GRAZE_EPS).collect();
        let (now, fresh) = if by_pair {
            (before.clone(), first_bits(before.len()))
        } else {
            (Vec::new(), 0)
        };
        GrazeWatch {
            on,
            by_pair,
            slack: least(&before) - GRAZE_EPS,
            before,
            now,
            due_at,
            y_before: y0,
            t_before: 0.0,
            w_before: Vector3::new(y0[4], y0[5], y0[6]).norm(),
            turned: 0.0,
            fresh,
            redos: 0,
            landing: false,
        }
    }

    /// Looks at the accepted step ending at (t, y); the watch goes off where the model offers
    /// no margins (followed one by one, that is looked at every step). With cut-off events
    /// (`sides.events`) it finds them instead of grazes and crossings: a step in which a pair
    /// leaves its side is taken again to land where it does (the watch then stays where the
    /// step began), and pairs at their cut-off where a step ends, moving on across it, are
    /// switched.
    fn look<M: TorqueModel>(&mut self, sides: &Sides<'_, '_, M>, t: f64, y: &[f64; 7]) -> Look {
        let w_now = Vector3::new(y[4], y[5], y[6]).norm();
        let h = t - self.t_before;
        let turn = 2.0 * w_now.max(self.w_before) * h;
        self.turned += turn;
        let seen = if self.turned + LOOK_AHEAD * turn >= self.slack || self.landing {
            match self.look_near(sides, y, h, turn) {
                Ok(seen) => seen,
                // the step is taken back, or the integration stops
                Err(seen) => return seen,
            }
        } else {
            self.fresh = 0;
            // no pair near its cut-off: whether the model still offers margins is all there
            // is to see
            let off = self.by_pair && !margins_of(sides.sys, y, true, 0, &mut self.now);
            if off {
                self.on = false;
                Look::Crossed
            } else {
                Look::Quiet
            }
        };
        (self.y_before, self.t_before, self.w_before) = (*y, t, w_now);
        seen
    }

    /// The pairs whose margins may have come near their cut-off (their decisions are made
    /// now), and those that may by the end of a next step that turns the ball up to
    /// [`LOOK_AHEAD`] times as far as this one (`turn`): their margins are computed now, so that
    /// they are at hand as the next step's start. Every pair while landing on an event or where
    /// they are not followed one by one. Also the least `due_at` of the others.
    fn due(&self, turn: f64) -> (SideMask, SideMask, f64) {
        if self.landing || !self.by_pair {
            let all = first_bits(self.now.len().max(self.before.len()));
            return (all, all, f64::INFINITY);
        }
        let (turned, ahead) = (self.turned, self.turned + LOOK_AHEAD * turn);
        let (mut due, mut soon, mut rest): (SideMask, SideMask, f64) = (0, 0, f64::INFINITY);
        for (i, &at) in self.due_at.iter().enumerate() {
            if at <= ahead {
                soon |= 1 << i;
                if at <= turned {
                    due |= 1 << i;
                }
            } else {
                rest = rest.min(at);
            }
        }
        (due, soon, rest)
    }

    /// [`GrazeWatch::look`] where some pairs may be near their cut-off: their margins at the
    /// step's start and end `h` later (`turn` the step's part of `turned`), and what they say;
    /// `Err` where the step is taken back or the integration stops at once.
    fn look_near<M: TorqueModel>(
        &mut self,
        sides: &Sides<'_, '_, M>,
        y: &[f64; 7],
        h: f64,
        turn: f64,
    ) -> Result<Look, Look> {
        let sys = sides.sys;
        let (due, soon, rest) = self.due(turn);
        std::mem::swap(&mut self.before, &mut self.now);
        let stale = due & !self.fresh;
        self.on = (stale == 0
            || margins_of(sys, &self.y_before, self.by_pair, stale, &mut self.before))
            && margins_of(sys, y, self.by_pair, soon, &mut self.now);
        let mut seen = Look::Quiet;
        if self.on && sides.events {
            match events::seen(sides, &self.before, &self.now, h, due) {
                Seen::Redo(s) if self.redos < MAX_REDOS => {
                    // the step is taken back: the watch stays at its start
                    std::mem::swap(&mut self.before, &mut self.now);
                    self.turned -= turn;
                    (self.fresh, self.landing) = (self.fresh | due, true);
                    self.redos += 1;
                    return Err(Look::Redo(s * h));
                }
                Seen::Redo(_) => seen = self.switch_beyond(sides, due),
                Seen::Flip(flips) => {
                    let grazing = events::each(flips, self.now.len())
                        .any(|i| barely_crosses(sides.side(i), self.before[i], self.now[i], h));
                    if grazing {
                        return Err(Look::Grazed);
                    }
                    sides.flip(flips);
                    seen = Look::Changed;
                }
                Seen::Quiet => {
                    let n = self.now.len();
                    let (a, b) = (&self.before, &self.now);
                    if events::each(due, n).any(|i| turns_back(sides.side(i), a[i], b[i], h)) {
                        return Err(Look::Grazed);
                    }
                }
            }
            (self.redos, self.landing) = (0, false);
        } else {
            let pairs = || events::each(due, self.now.len()).map(|i| (self.before[i], self.now[i]));
            if self.on && pairs().any(|(a, b)| grazes(a, b, h)) {
                return Err(Look::Grazed);
            }
            if !self.on || pairs().any(|(a, b)| (a.0 < 0.0) != (b.0 < 0.0)) {
                seen = Look::Crossed;
            }
        }
        self.fresh = soon;
        self.wait(soon, rest);
        Ok(seen)
    }

    /// After the margins of the pairs of `due` were computed: when each is computed again, and
    /// when the next is (`rest`: the least of the others).
    fn wait(&mut self, due: SideMask, rest: f64) {
        if !self.by_pair {
            self.slack = self.turned + least(&self.now) - GRAZE_EPS;
            return;
        }
        let mut slack = rest;
        for i in events::each(due, self.now.len()) {
            let at = self.turned + self.now[i].0.abs() - GRAZE_EPS;
            self.due_at[i] = at;
            slack = slack.min(at);
        }
        self.slack = slack;
    }

    /// After [`MAX_REDOS`] landings on one event: the pairs (of those computed, `due`) on the
    /// wrong side of their cut-off where the step ends are switched there.
    fn switch_beyond<M: TorqueModel>(&self, sides: &Sides<'_, '_, M>, due: SideMask) -> Look {
        let flips = bits_of(
            events::each(due, self.now.len()).filter(|&i| sides.side(i) * self.now[i].0 < 0.0),
        );
        if flips == 0 {
            return Look::Quiet;
        }
        sides.flip(flips);
        Look::Changed
    }
}

/// The fast path's fallback: the settle from the start by Dopri5 at the tolerances `(rtol,
/// atol)` ([`FALLBACK_TOL`], or [`unheld_tolerance`] for a set that no strict minimum holds), its
/// evaluations counted on top of the `spent` ones, its steps in the trace in place of the loose
/// run's.
fn settle_tight<M: TorqueModel>(
    sys: &RotorDynamics<'_, M>,
    y0: [f64; 7],
    params: SettleParams,
    spent: u32,
    (mut trace, traced): Tail<'_>,
    (rtol, atol): (f64, f64),
) -> SettleResult {
    let tight = SettleParams {
        rtol,
        atol,
        ..params
    };
    if let Some(tr) = trace.as_deref_mut() {
        // the loose run's steps are given up with it
        tr.truncate(traced);
    }
    let mut r = settle_dopri5(sys, y0, tight, trace);
    r.evaluations = r.evaluations.saturating_add(spent);
    r
}

/// The fast path's least first step, in units of the time scale sqrt(I / (n K)) of its n
/// active pairs: from rest Hairer's estimate starts 50 to 100 times shorter, and the step took
/// 6 or 7 steps to grow out of it. On the 200 sets of research/settle_sets.rs the median settle
/// takes 70.5 evaluations instead of 81; on the 28,000 of research/basins.rs none lands in
/// another equilibrium, and 297 settle times are outside the reference's bounds (307 without).
/// 0.2 saves 2 evaluations more but leaves 319 outside.
const FIRST_STEP: f64 = 0.1;

/// The loosest relative tolerance of the fast path's nonlinear phase (a looser scenario rtol is
/// tightened to it) ...
const NONLINEAR_RTOL: f64 = 1e-2;
/// ... and, for light damping, at most this times the damping ratio squared (zeta = c over
/// 2 sqrt(K I), K one aligned pair's stiffness), never below [`NONLINEAR_RTOL_FLOOR`]: the
/// stepper's error per oscillation must stay small against the damping's loss per oscillation
/// (about 4 pi zeta of the energy). At 0.2 of critical damping and rtol 1e-2, the stepper's own
/// damping of the oscillations, not the physics', decided when sets came near their minimum
/// (settle times 0.2 to 0.6 s early) and 3 sets in 1,000 ended in another equilibrium; rtol 1e-3
/// still put 1 in 2,000 there, 1e-4 none (research/basins.rs).
const NONLINEAR_RTOL_PER_ZETA2: f64 = 2.5e-3;
const NONLINEAR_RTOL_FLOOR: f64 = 1e-5;

/// A pair's magnet that comes this close to its well's cut-off (in cosine: 1e-4 is 0.013
/// degrees at a 25 degree cut-off) and turns back, or dips across and back within a step, sends
/// the fast path to its tight fallback: whether it leaves reach there, and the torque jumps, is
/// decided by errors its tolerance allows. On research/basins.rs one set in 4,000 of the
/// cosine, light-damping kind (seeds 18 and 19) ended 0.12 and 0.32 rad from the reference's
/// equilibrium so; 1e-5 caught seed 19's only. The cost: the sets that graze (3 to 15% of the
/// random sets, most at light damping) settle at tight tolerances.
const GRAZE_EPS: f64 = 1e-4;

/// How many times as far as the step at hand the graze watch expects the next step to turn the
/// ball at most: the margins of the pairs that may come near their cut-off within that are
/// computed ahead, at the step's end, so that the next step has them at its start. Only the
/// work depends on it (a margin not at hand is computed where it is needed).
const LOOK_AHEAD: f64 = 2.0;

/// Points of a step's interpolant at which [`grazes`] looks.
const GRAZE_SAMPLES: u32 = 16;

/// Whether a pair's cut-off margin m, (m0, dm0/dt) at a step's start and (m1, dm1/dt) at its
/// end `h` later, grazes the cut-off over the step: comes within [`GRAZE_EPS`] of 0 on the
/// cubic Hermite interpolant without ending on the other side, or dips across and back.
fn grazes((m0, rate0): (f64, f64), (m1, rate1): (f64, f64), h: f64) -> bool {
    if m0.signum() != m1.signum() {
        // a crossing, not a graze
        return false;
    }
    near_zero_on_step((m0, rate0 * h), (m1, rate1 * h), true)
}

/// Whether the cubic Hermite interpolant of a margin over a step (m0 and m1 at its ends, d0
/// and d1 its rates times the step) comes within [`GRAZE_EPS`] of 0 at one of its
/// [`GRAZE_SAMPLES`] + 1 points, or, with `across`, lies on the other side of 0 from m0 there.
fn near_zero_on_step((m0, d0): (f64, f64), (m1, d1): (f64, f64), across: bool) -> bool {
    let dm = m1 - m0;
    // the interpolant departs from the chord by at most a quarter of |d0 - dm| + |d1 - dm|:
    // most steps are ruled out here
    if m0.abs().min(m1.abs()) > GRAZE_EPS + 0.25 * ((d0 - dm).abs() + (d1 - dm).abs()) {
        return false;
    }
    (0..=GRAZE_SAMPLES).any(|j| {
        let [a0, b0, a1, b1] = hermite_weights(j as f64 / GRAZE_SAMPLES as f64);
        let m = a0 * m0 + b0 * d0 + a1 * m1 + b1 * d1;
        m.abs() < GRAZE_EPS || (across && m.signum() != m0.signum())
    })
}

/// Whether a pair's margin (cut-off events: the pair on its side) turns back from its cut-off
/// within a step having come within [`GRAZE_EPS`] of it: approaching it at the step's
/// start, receding at its end (rates by `side`: +1 for a pair within reach), and within
/// [`GRAZE_EPS`] of 0 on the cubic Hermite interpolant.
fn turns_back(side: f64, (m0, rate0): (f64, f64), (m1, rate1): (f64, f64), h: f64) -> bool {
    if !(side * rate0 <= 0.0 && side * rate1 > 0.0) {
        return false;
    }
    near_zero_on_step((m0, rate0 * h), (m1, rate1 * h), false)
}

/// Whether a pair at its cut-off where a step ends, moving on across it (cut-off events: the
/// pair on its `side`), crosses only barely: its margin's acceleration there, on the cubic
/// Hermite interpolant of the step from (m0, dm0/dt) to (m1, dm1/dt) over `h`, turns it back,
/// and would have turned it back within [`GRAZE_EPS`] beyond the cut-off (its rate squared over
/// twice the acceleration). Whether such a pair crosses at all hangs on errors the loose
/// tolerance allows: an approach the tight integration turns back 1e-3 degrees short of a 25
/// degree cut-off crossed it at 0.4 degrees a second on the loose one (the settle-graze case of
/// `tests/it/basins.rs`), and ended 0.011 rad from the reference's equilibrium.
fn barely_crosses(side: f64, (m0, rate0): (f64, f64), (m1, rate1): (f64, f64), h: f64) -> bool {
    if !(h > 0.0 && side * rate1 < 0.0) {
        return false;
    }
    // p(s) = the interpolant over the step, s in [0, 1]: p''(1) = 6 (m0 - m1) + 2 d0 + 4 d1
    let accel = (6.0 * (m0 - m1) + 2.0 * rate0 * h + 4.0 * rate1 * h) / (h * h);
    side * accel > 0.0 && rate1 * rate1 < 2.0 * GRAZE_EPS * side * accel
}

/// The least damping ratio (one aligned pair's, as for [`NONLINEAR_RTOL_PER_ZETA2`]) at which a
/// "coils" settle that leaves the skin of its lists goes on by the fast path ([`go_on_beyond`]);
/// below it the settle starts again tightly, as it always did. On research/basins.rs
/// (`--coils`, 1,000 sets a kind) going on put sets in another equilibrium than the
/// reference's at 0.2 of critical damping (cosine wells: 2 with seed 17, 4 with seed 18, 0.03
/// to 0.13 rad away; gaussian: 1 with seed 18) and at 0.7 (cosine, seed 18: 1, 0.03 rad), with
/// 4 (seed 17) and 12 (seed 18) more outside its bounds in all; at 2 none, and as many outside
/// its bounds as starting again tightly, for up to 1.5% fewer evaluations. The soft-wells
/// scenario is at 1.6, broad-wells at 2.8.
const GO_ON_ZETA: f64 = 1.0;

/// Tight approaches to grazes one fast settle may take before the next graze sends it to the
/// tight fallback.
const TIGHT_APPROACHES: u32 = 3;

/// At t_max without a strict minimum, the fast path falls back to the tight integration only
/// if the ball is this close to the settle test (times its tolerances): a free rotation the
/// stepper neither damps nor stops at its stability limit. A ball still moving faster than that
/// is not settling by t_max on either path, and is reported so at once. On research/basins.rs
/// (seeds 17, 18 and 19: 84,000 sets) 30 gives the same results as 100 did; 10 let 11 sets of
/// seed 17 say "not settled" where the reference settles before t_max, 20 none. On the 200
/// sets of research/settle_sets.rs, 30 spares the tight run of the two orders of a set still
/// creeping at t_max (2,700 evaluations each): 103 evaluations per settle on average, not 127.
const NEAR_REST: f64 = 30.0;

/// Tolerances of the tight integration the fast path falls back to. On the 28,000 sets of
/// research/basins.rs, 1e-8 leaves as many sets outside the reference's bounds as 1e-9 (303 and
/// 302, none in another equilibrium) for 21% fewer evaluations; 1e-7 leaves 322, DOP853 at 1e-9
/// 341. (Before the reference applied its settle test within its steps, 1e-8 seemed worse: 756
/// against 666, most of them the reference's own late detection.)
const FALLBACK_RTOL: f64 = 1e-8;
const FALLBACK_ATOL: f64 = 1e-10;
const FALLBACK_TOL: (f64, f64) = (FALLBACK_RTOL, FALLBACK_ATOL);

/// The tight integration's tolerances (rtol, atol) for a set that ended (settled, or near rest
/// at t_max) where no strict minimum holds it, followed again from the start (`conclude`): its
/// path has no graze to resolve, only a free direction whose end the whole coast decides, and
/// it is integrated at [`UNHELD_RTOL`], or at [`FALLBACK_TOL`] where the damping is light (the
/// rtol scaled by the square of the damping ratio over [`UNHELD_ZETA`], for one aligned pair of
/// stiffness `k1`, is tighter than the fallback's).
fn unheld_tolerance<M: TorqueModel>(sys: &RotorDynamics<'_, M>, k1: f64) -> (f64, f64) {
    let rtol = UNHELD_RTOL * (damping_ratio(sys, k1) / UNHELD_ZETA).powi(2).min(1.0);
    if rtol > FALLBACK_RTOL {
        (rtol, rtol * (FALLBACK_ATOL / FALLBACK_RTOL))
    } else {
        FALLBACK_TOL
    }
}

/// The relative tolerance of the tight run of a set no strict minimum holds. On the 4,000
/// planner-like sets of research/settle_sets.rs (0.7 of critical damping; 81 such sets, 23% of
/// the evaluations at [`FALLBACK_RTOL`]) 1e-7 takes 26% fewer evaluations for them (105,796
/// instead of 142,990), the worst of them 2.8e-6 rad from the reference, none outside the
/// bounds of research/basins.rs; 1e-6 put one outside (7.6e-6 rad), 1e-5 eight (2.6e-4 rad).
/// On research/basins.rs (seed 17) 1e-7 at every damping put 8 more of the light-damping
/// (0.2) gaussian sets outside the bounds (89 against 81): hence [`UNHELD_ZETA`]. Restarting
/// the tight run from the loose run's state before the first cut-off event instead of from the
/// start saved 14% of their evaluations but put 5 of the 81 outside the bounds (1.5e-4 rad);
/// from before the last event, 33% and 9 outside: the loose run is not trusted that far.
const UNHELD_RTOL: f64 = 1e-7;
/// Below this damping ratio the unheld sets' rtol is scaled down by the ratio's square (to the
/// fallback's at 0.2 and below).
const UNHELD_ZETA: f64 = 0.65;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::{Orientation, Pair};

    #[test]
    fn the_hermite_weights_interpolate_a_cubic_exactly() {
        let p = |t: f64| 0.3 - 1.2 * t + 0.7 * t * t + 2.1 * t * t * t;
        let dp = |t: f64| -1.2 + 1.4 * t + 6.3 * t * t;
        let (t0, h) = (0.4, 0.25);
        for j in 0..=8 {
            let s = j as f64 / 8.0;
            let [a0, b0, a1, b1] = hermite_weights(s);
            let m = a0 * p(t0) + b0 * h * dp(t0) + a1 * p(t0 + h) + b1 * h * dp(t0 + h);
            assert!((m - p(t0 + s * h)).abs() < 1e-14, "s = {s}");
        }
    }

    #[test]
    fn a_margin_that_dips_to_the_cut_off_and_back_grazes_it() {
        // m(t) = c + a (t - h/2)^2 over a step h: at its ends 0.01, its least c mid-step
        let h = 0.1;
        let step = |c: f64| {
            let a = (0.01 - c) / (h * h / 4.0);
            ((0.01, -a * h), (0.01, a * h))
        };
        let (start, end) = step(0.5 * GRAZE_EPS);
        assert!(grazes(start, end, h));
        // dipping across and back is a graze too
        let (start, end) = step(-0.002);
        assert!(grazes(start, end, h));
        // staying well clear is not
        let (start, end) = step(0.005);
        assert!(!grazes(start, end, h));
        // nor is a crossing: the ball leaves reach (or comes into it) for good
        assert!(!grazes((0.01, -0.2), (-0.01, -0.2), h));
    }

    #[test]
    fn an_unheld_set_is_followed_at_1e_7_unless_the_damping_is_light() {
        let (torques, body) = super::super::prototype_physics();
        let k1 = torques
            .stiffness_scale()
            .expect("gaussian wells have a stiffness scale");
        let active = [Pair::new(0, 14)];
        // the tolerances at a damping ratio zeta for one aligned pair
        let at = |zeta: f64| {
            let body = super::super::Body {
                damping: zeta * 2.0 * (k1 * body.inertia.x).sqrt(),
                ..body
            };
            unheld_tolerance(&RotorDynamics::new(&torques, &active, body), k1)
        };
        for zeta in [0.7, 2.0] {
            let (rtol, atol) = at(zeta);
            assert_eq!(rtol, UNHELD_RTOL, "zeta {zeta}");
            assert!((atol - 1e-9).abs() < 1e-24, "zeta {zeta}: atol {atol}");
        }
        // light damping keeps the fallback's tolerances to the bit
        assert_eq!(at(0.2), FALLBACK_TOL);
        assert_eq!(at(0.05), FALLBACK_TOL);
        // in between, scaled by the damping ratio squared
        let (rtol, _) = at(0.4);
        let expected = UNHELD_RTOL * (0.4f64 / UNHELD_ZETA).powi(2);
        assert!(
            (rtol - expected).abs() < 1e-12 * expected,
            "{rtol} against {expected}"
        );
        assert!(rtol > FALLBACK_RTOL && rtol < UNHELD_RTOL);
    }

    #[test]
    fn the_fast_path_settles_where_the_reference_does() {
        let (torques, body) = super::super::prototype_physics();
        let q0 = Orientation::identity();
        let params = SettleParams::default();
        for set in [
            vec![Pair::new(0, 14), Pair::new(12, 26)],
            vec![Pair::new(0, 14), Pair::new(12, 26), Pair::new(5, 40)],
            vec![Pair::new(0, 14)],
        ] {
            let fast = super::super::settle(&torques, &set, &q0, body, params);
            let reference = super::super::settle(&torques, &set, &q0, body, params.reference());
            assert_eq!(fast.settled, reference.settled, "{set:?}");
            let apart = fast.q.angle_to(&reference.q);
            assert!(apart < 1e-3, "{set:?}: {apart} rad apart");
            let (tf, tr) = (fast.settle_time_s, reference.settle_time_s);
            assert!(
                (tf - tr).abs() <= 0.05 * tr + 1e-3,
                "{set:?}: {tf} s against {tr} s"
            );
            // for fewer evaluations
            assert!(fast.evaluations < reference.evaluations, "{set:?}");
        }
    }
}
