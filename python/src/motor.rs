//! `spherestep.Scenario` and `spherestep.Motor`: a checked scenario file and the motor made
//! from it, whose methods are the library's entry points (`Motor::{settle, settle_many, plan,
//! simulate, wells, run}`), each taking its arguments as the command line does and checking
//! them as it does.

use crate::convert::{self, shown};
use crate::replaced;
use crate::results::{self, Plan, Run, SettleResult, SettleTable, Simulation, Wells};
use crate::{arg_err, lib_err};
use numpy::PyArray2;
use pyo3::prelude::*;
use pyo3::IntoPyObjectExt;
use spherestep::io::scenario::{parse_pairs_per_step, ChangeNames, PlanChanges, PlanInput};
use spherestep::planning::commutation::pair_gap;
use spherestep::planning::holding::Holding;
use spherestep::planning::options::{LoopNames, LoopOptions, LoopPlan, RowsFrom, DEFAULT_SEED};
use spherestep::Cancel;
use spherestep::{PairsPerStep, PlanRow};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::time::Duration;

/// A scenario: the motor (rotor and stator packings, magnet wells), the body and damping, the
/// settle settings and the `[plan]` defaults, read and checked from a TOML file.
#[pyclass(frozen, module = "spherestep")]
#[derive(Clone)]
pub struct Scenario {
    pub(crate) sc: Arc<spherestep::Scenario>,
    /// The TOML text it was made from (`replace` changes it and checks the result again).
    text: Arc<str>,
    /// The file it came from (None: text, or the built-in prototype).
    file: Option<PathBuf>,
}

/// What `from_toml` calls text that names no file (in errors, and the folder relative paths
/// start from: the current one).
const TEXT_PATH: &str = "<string>";

/// The built-in prototype's name and description, as `scenarios/prototype.toml` (which holds
/// every default) says them; every other value is the default.
const PROTOTYPE_TEXT: &str = "name = \"prototype\"\n\
    description = \"12 inch rotor, 80 magnets (octahedral), 16 coils (icosahedral cap), \
    gaussian wells\"\n";

#[pymethods]
impl Scenario {
    /// Reads and checks a scenario file (TOML). A file that cannot be read, is not a scenario
    /// or holds a value not allowed raises `spherestep.Error` naming the file and the field.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Scenario> {
        let text = spherestep::io::input::text(&path).map_err(lib_err)?;
        let mut sc = spherestep::Scenario::from_toml(&text, &path).map_err(lib_err)?;
        sc.files.insert(0, path.clone());
        Ok(Scenario {
            sc: Arc::new(sc),
            text: text.into(),
            file: Some(path),
        })
    }

    /// Parses and checks scenario text; `path` names it in errors and anchors the relative
    /// paths it names (point files, torque tables): by default the text names no file (`path`
    /// is None, errors say `<string>`) and relative paths start from the current folder.
    #[staticmethod]
    #[pyo3(signature = (text, path = None))]
    fn from_toml(text: &str, path: Option<PathBuf>) -> PyResult<Scenario> {
        let named = path.clone().unwrap_or_else(|| PathBuf::from(TEXT_PATH));
        let sc = spherestep::Scenario::from_toml(text, &named).map_err(lib_err)?;
        Ok(Scenario {
            sc: Arc::new(sc),
            text: text.into(),
            file: path,
        })
    }

    /// The built-in prototype with every default (what an empty scenario file gives), named
    /// and described as `scenarios/prototype.toml` names it.
    #[staticmethod]
    fn prototype() -> PyResult<Scenario> {
        let sc = spherestep::Scenario::from_toml(PROTOTYPE_TEXT, Path::new(PROTOTYPE_PATH))
            .map_err(lib_err)?;
        Ok(Scenario {
            sc: Arc::new(sc),
            text: PROTOTYPE_TEXT.into(),
            file: None,
        })
    }

    /// A copy of the scenario with some of its values replaced, checked as a file would be:
    /// `changes` maps keys `"section.key"` (`"body.damping"`, `"magnets.sigma_deg"`) or
    /// top-level keys (`"name"`) to values, and each keyword argument is a top-level key or a
    /// section given as a dict (`body={"damping": 0.8}`). A value None removes the key (its
    /// default). An unknown key, or a value not allowed, raises `spherestep.Error` naming the
    /// key. The copy keeps the scenario's `path` (relative paths still start from it).
    #[pyo3(signature = (changes = None, /, **kwargs))]
    fn replace(
        &self,
        changes: Option<&Bound<'_, pyo3::types::PyDict>>,
        kwargs: Option<&Bound<'_, pyo3::types::PyDict>>,
    ) -> PyResult<Scenario> {
        let mut list = Vec::new();
        for d in changes.into_iter().chain(kwargs) {
            for (k, v) in d.iter() {
                let key: String = k
                    .extract()
                    .map_err(|_| arg_err("changes", format!("keys as text, got {}", shown(&k))))?;
                replaced::flatten(&key, &v, &mut list)?;
            }
        }
        let (text, mut sc) = replaced::apply(&self.text, &self.sc.path, &list)?;
        // a loaded file stays one of the files an output must not replace
        if let Some(f) = self
            .file
            .as_ref()
            .filter(|f| self.sc.files.first() == Some(*f))
        {
            sc.files.insert(0, f.clone());
        }
        Ok(Scenario {
            sc: Arc::new(sc),
            text: text.into(),
            file: self.file.clone(),
        })
    }

    /// The motor of the scenario: its physics, whose methods settle, plan, simulate and run.
    fn motor(&self) -> Motor {
        Motor {
            motor: self.sc.motor(),
            sc: self.sc.clone(),
            scenario: self.clone(),
        }
    }

    /// The scenario's name.
    #[getter]
    fn name(&self) -> &str {
        &self.sc.name
    }

    /// What the scenario is for, as its file says.
    #[getter]
    fn description(&self) -> &str {
        &self.sc.description
    }

    /// The file it was read from (or the `path` of `from_toml`); None for text that names no
    /// file and for the built-in prototype.
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.file.clone()
    }

    /// The scenario's TOML text (with `replace`'s changes: the values as TOML writes them).
    #[getter]
    fn toml(&self) -> &str {
        &self.text
    }

    /// Where the rotor's magnets are: unit vectors in the body frame, shape `(magnets, 3)`.
    #[getter]
    fn rotor<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        results::vectors(py, self.sc.rotor.points.iter().map(|p| p.into_inner()))
    }

    /// Where the stator's coils are: unit vectors in the world frame, shape `(coils, 3)`.
    #[getter]
    fn stator<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        results::vectors(py, self.sc.stator.points.iter().map(|p| p.into_inner()))
    }

    fn __repr__(&self) -> String {
        format!(
            "Scenario(name={:?}, path={}, magnets={}, coils={})",
            self.sc.name,
            match &self.file {
                Some(p) => format!("{:?}", p.display().to_string()),
                None => "None".into(),
            },
            self.sc.rotor.len(),
            self.sc.stator.len()
        )
    }
}

/// The path the library gives the built-in prototype (`spherestep::Scenario::prototype`).
const PROTOTYPE_PATH: &str = "<built-in prototype>";

/// The starts of `settle_many`: one for every set, or one per set.
enum Starts {
    One(spherestep::Orientation),
    PerSet(Vec<spherestep::Orientation>),
}

/// Whether `q0` is meant as one start per set: a 2-d array, or a sequence whose first item is
/// itself a sequence (not text); one start is 4 numbers.
fn one_per_set(q0: &Bound<'_, PyAny>) -> bool {
    if let Ok(a) = q0.cast::<numpy::PyUntypedArray>() {
        use numpy::PyUntypedArrayMethods;
        return a.ndim() == 2;
    }
    if q0.is_instance_of::<pyo3::types::PyString>() {
        return false;
    }
    let Ok(mut items) = q0.try_iter() else {
        return false;
    };
    match items.next() {
        Some(Ok(first)) => {
            !first.is_instance_of::<pyo3::types::PyString>()
                && (first.try_iter().is_ok() || first.cast::<numpy::PyUntypedArray>().is_ok())
        }
        _ => false,
    }
}

/// `settle_many`'s `q0` for `n` sets: None (the identity for all), one orientation for all,
/// or a sequence of `n` orientations (an array of shape `(n, 4)` too), one per set.
fn starts(q0: Option<&Bound<'_, PyAny>>, n: usize) -> PyResult<Starts> {
    let q0 = match q0 {
        Some(q) if !q.is_none() => q,
        _ => return Ok(Starts::One(spherestep::Orientation::identity())),
    };
    // A one-shot iterator (a generator) once in a list: it is looked at twice below.
    let listed;
    let q0 = match q0.try_iter() {
        Ok(items)
            if q0.cast::<pyo3::types::PySequence>().is_err()
                && q0.cast::<numpy::PyUntypedArray>().is_err() =>
        {
            let items = items.collect::<PyResult<Vec<_>>>().map_err(|_| {
                arg_err("q0", format!("orientations qx,qy,qz,qw, got {}", shown(q0)))
            })?;
            listed = pyo3::types::PyList::new(q0.py(), items)?.into_any();
            &listed
        }
        _ => q0,
    };
    if !one_per_set(q0) {
        return Ok(Starts::One(convert::orientation(q0, "q0")?));
    }
    if let Ok(a) = q0.cast::<numpy::PyUntypedArray>() {
        use numpy::PyUntypedArrayMethods;
        if a.shape()[1] != 4 {
            return Err(arg_err(
                "q0",
                format!(
                    "one start qx,qy,qz,qw for all the sets, or an array of shape ({n}, 4), \
                     one start per set, got an array of shape ({}, {})",
                    a.shape()[0],
                    a.shape()[1]
                ),
            ));
        }
    }
    let mut out = Vec::new();
    for (k, q) in q0.try_iter()?.enumerate() {
        out.push(convert::orientation(&q?, &format!("q0[{k}]"))?);
    }
    if out.len() != n {
        return Err(arg_err(
            "q0",
            format!(
                "one start for all the sets, or one start per set ({n} sets), got {} starts",
                out.len()
            ),
        ));
    }
    Ok(Starts::PerSet(out))
}

/// A scenario's motor: its torques, body and settle parameters. Its methods are the library's
/// entry points; they release the GIL while they compute.
#[pyclass(frozen, module = "spherestep")]
pub struct Motor {
    pub(crate) motor: spherestep::Motor,
    pub(crate) sc: Arc<spherestep::Scenario>,
    /// The scenario as Python made it (its text and file).
    scenario: Scenario,
}

impl Motor {
    /// Checks pairs given from Python against the motor (indices in range, each coil once).
    fn active(&self, obj: &Bound<'_, PyAny>, arg: &str) -> PyResult<Vec<spherestep::Pair>> {
        let active = convert::pairs(obj, arg)?;
        self.sc.check_active(&active, arg).map_err(lib_err)?;
        Ok(active)
    }

    /// Checks that `plant` has this motor's packings (a plan made here can be played there).
    fn physics<'a>(&'a self, plant: Option<&'a Motor>) -> PyResult<&'a Motor> {
        match plant {
            None => Ok(self),
            Some(p) => {
                self.sc
                    .check_same_packings(&p.sc, "plant")
                    .map_err(lib_err)?;
                Ok(p)
            }
        }
    }
}

/// What the Python arguments are called in a refusal of a plan setting.
const ARGUMENT_NAMES: ChangeNames = ChangeNames {
    axis: "axis",
    angle: "angle",
    scheme: "scheme",
    model: "model",
    pairs: "pairs",
    start: "start",
    to: "to",
};

/// The changes of the scenario's `[plan]` settings the arguments given ask for, each read as
/// its type here; the library makes and checks them as it does the command line's
/// (`Scenario::plan_with`, naming them by [`ARGUMENT_NAMES`]).
#[allow(clippy::too_many_arguments)]
fn plan_changes<'a>(
    axis: Option<&Bound<'_, PyAny>>,
    angle: Option<f64>,
    scheme: Option<&'a str>,
    model: Option<&'a str>,
    pairs: Option<&Bound<'_, PyAny>>,
    start: Option<&Bound<'_, PyAny>>,
    to: Option<&Bound<'_, PyAny>>,
) -> PyResult<PlanChanges<'a>> {
    Ok(PlanChanges {
        axis: axis.map(|a| convert::axis(a, "axis")).transpose()?,
        angle_deg: angle,
        scheme,
        model,
        pairs: pairs.map(pairs_per_step).transpose()?,
        start: start
            .map(|f| convert::orientation(f, "start"))
            .transpose()?,
        to: to.map(|t| convert::orientation(t, "to")).transpose()?,
    })
}

/// Pairs per step: an integer K (exactly K) or text `K` or `2-K` (2 to K, chosen per step).
fn pairs_per_step(k: &Bound<'_, PyAny>) -> PyResult<PairsPerStep> {
    let parsed = match k.extract::<usize>() {
        Ok(n) => Some(PairsPerStep::exactly(n)),
        Err(_) => k
            .extract::<String>()
            .ok()
            .and_then(|t| parse_pairs_per_step(&t)),
    };
    parsed.ok_or_else(|| {
        arg_err(
            "pairs",
            format!(
                "K (exactly K pairs per step) or '2-K' (2 to K), got {}",
                shown(k)
            ),
        )
    })
}

/// How many sets `settle_many` settles between two looks for Ctrl-C.
const SETTLE_CHUNK: usize = 2048;

/// A copy of `motor` with a cancellation token of its own (never set, it changes no result).
fn cancellable(motor: &spherestep::Motor) -> spherestep::Motor {
    spherestep::Motor {
        cancel: Cancel::new(),
        ..motor.clone()
    }
}

/// Runs `work` on a thread of its own while this one waits with the GIL released, taking the
/// GIL back every 50 ms to look for a signal: on Ctrl-C (or any signal handler's exception) it
/// sets `cancel`, so that the planners give up at their next look, waits for `work` to stop
/// and raises the exception. A panic in `work` is raised as it would be on this thread.
fn interruptible<T: Send>(
    py: Python<'_>,
    cancel: &Cancel,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    let done = Arc::new((Mutex::new(false), Condvar::new()));
    /// Says "done" when the work ends, also by a panic.
    struct Done(Arc<(Mutex<bool>, Condvar)>);
    impl Drop for Done {
        fn drop(&mut self) {
            *self.0 .0.lock().unwrap_or_else(PoisonError::into_inner) = true;
            self.0 .1.notify_all();
        }
    }
    std::thread::scope(|s| {
        let signal = Done(done.clone());
        let handle = s.spawn(move || {
            let _signal = signal;
            work()
        });
        loop {
            let finished = py.detach(|| {
                let (flag, cv) = &*done;
                let g = flag.lock().unwrap_or_else(PoisonError::into_inner);
                let (g, _) = cv
                    .wait_timeout_while(g, Duration::from_millis(50), |d| !*d)
                    .unwrap_or_else(PoisonError::into_inner);
                *g
            });
            if finished {
                break;
            }
            if let Err(e) = py.check_signals() {
                cancel.cancel();
                let _ = handle.join();
                return Err(e);
            }
        }
        match handle.join() {
            Ok(t) => Ok(t),
            Err(panic) => std::panic::resume_unwind(panic),
        }
    })
}

/// The most worker threads `settle_many` starts (a pool of its own for the call).
const MAX_THREADS: i64 = 1024;

/// `settle_many`'s pool of `threads` worker threads (None: rayon's global pool, one per core).
fn thread_pool(threads: Option<i64>) -> PyResult<Option<rayon::ThreadPool>> {
    match threads {
        None => Ok(None),
        Some(n) if !(1..=MAX_THREADS).contains(&n) => Err(arg_err(
            "threads",
            format!("at least 1 and at most {MAX_THREADS} worker threads, got {n}"),
        )),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n as usize)
            .build()
            .map(Some)
            .map_err(|source| {
                lib_err(spherestep::Error::Threads {
                    threads: n as usize,
                    source,
                })
            }),
    }
}

/// What the Python arguments are called in a refusal of the loop's options.
const LOOP_ARGUMENT_NAMES: LoopNames = LoopNames {
    noise_deg: "sensor_noise_deg",
    max_steps: "max_steps",
    motion: "axis/angle",
};

/// The loop's options from the arguments, checked before anything is computed (the library's
/// `LoopOptions::check`, naming them by [`LOOP_ARGUMENT_NAMES`]); the sensor's arguments only
/// with `closed_loop`, as the command line's only with `--closed-loop`.
fn loop_options(
    closed_loop: bool,
    noise_deg: f64,
    seed: Option<u64>,
    max_steps: Option<usize>,
    identify: bool,
) -> PyResult<LoopOptions> {
    let o = LoopOptions {
        closed: closed_loop,
        noise_deg,
        seed: seed.unwrap_or(DEFAULT_SEED),
        max_steps,
        identify,
    };
    // the options' own refusals first, then the sensor's arguments without closed_loop
    o.check(&LOOP_ARGUMENT_NAMES).map_err(lib_err)?;
    if !closed_loop && (noise_deg != 0.0 || seed.is_some() || max_steps.is_some() || !identify) {
        return Err(arg_err(
            "closed_loop",
            "True with sensor_noise_deg, seed, max_steps or identify (as the command line's \
             --closed-loop: the open loop plays the plan as it is, measured without noise)",
        ));
    }
    Ok(o)
}

/// The loop's seed and step limit as Python gives them (any integers), checked for their type.
fn loop_numbers(
    seed: Option<i128>,
    max_steps: Option<i64>,
) -> PyResult<(Option<u64>, Option<usize>)> {
    let seed = match seed {
        None => None,
        Some(n) => Some(
            u64::try_from(n)
                .map_err(|_| arg_err("seed", format!("a whole number in [0, 2^64), got {n}")))?,
        ),
    };
    let max_steps = match max_steps {
        None => None,
        Some(n) => Some(
            usize::try_from(n)
                .map_err(|_| arg_err("max_steps", format!("a whole number >= 1, got {n}")))?,
        ),
    };
    Ok((seed, max_steps))
}

/// The rows of `plan` (a `Plan`, or the path of a plan file), checked against the scenario by
/// the library (`Scenario::checked_rows`).
fn rows_of(sc: &spherestep::Scenario, plan: &Bound<'_, PyAny>) -> PyResult<Vec<PlanRow>> {
    let rows = if let Ok(p) = plan.cast::<Plan>() {
        let rows = p.get().plan.rows.clone();
        sc.checked_rows(PlanInput::Rows {
            rows,
            argument: "plan",
        })
    } else if let Ok(path) = plan.extract::<PathBuf>() {
        sc.checked_rows(PlanInput::File(&path))
    } else {
        return Err(arg_err(
            "plan",
            format!("a Plan or the path of a plan file, got {}", shown(plan)),
        ));
    };
    rows.map_err(lib_err)
}

#[pymethods]
impl Motor {
    /// Settles the ball from rest at `q0` (`[qx, qy, qz, qw]`, default identity) under the
    /// active set `pairs`: text `"0:14,12:26"` or a sequence of `(coil, magnet)` pairs.
    #[pyo3(signature = (pairs, q0 = None))]
    fn settle(
        &self,
        py: Python<'_>,
        pairs: &Bound<'_, PyAny>,
        q0: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<SettleResult> {
        let active = self.active(pairs, "pairs")?;
        let q0 = convert::orientation_or_identity(q0, "q0")?;
        let r = py.detach(|| self.motor.settle(&active, &q0));
        Ok(SettleResult::new(&self.sc, active, r))
    }

    /// Settles each of `sets` (each an active set as `settle` takes it) from `q0`, in
    /// parallel with the GIL released, on `threads` worker threads (default: one per core);
    /// the results in the sets' order, the same on any number of threads. `q0` is one start
    /// for all the sets (`[qx, qy, qz, qw]`, default identity) or one start per set (a
    /// sequence of as many orientations as sets, or an array of shape `(sets, 4)`): set k from
    /// `q0[k]`, as `settle(sets[k], q0[k])`. The results are columns: numpy arrays with one
    /// row per set.
    #[pyo3(signature = (sets, q0 = None, threads = None))]
    fn settle_many(
        &self,
        py: Python<'_>,
        sets: &Bound<'_, PyAny>,
        q0: Option<&Bound<'_, PyAny>>,
        threads: Option<i64>,
    ) -> PyResult<SettleTable> {
        if sets.is_instance_of::<pyo3::types::PyString>() {
            return Err(arg_err(
                "sets",
                format!(
                    "a sequence of active sets, got the text {} (one set: use settle)",
                    shown(sets)
                ),
            ));
        }
        let items = sets.try_iter().map_err(|_| {
            arg_err(
                "sets",
                format!("a sequence of active sets, got {}", shown(sets)),
            )
        })?;
        let mut list = Vec::new();
        for (k, set) in items.enumerate() {
            list.push(self.active(&set?, &format!("sets[{k}]"))?);
        }
        let q0 = starts(q0, list.len())?;
        let pool = thread_pool(threads)?;
        let sc = &self.sc;
        let cancel = Cancel::new();
        let (rs, holding) = interruptible(py, &cancel, || {
            // In chunks, so that Ctrl-C stops it between two (each set's settle is its own:
            // the same results however the sets are cut).
            let work = || {
                let mut rs = Vec::with_capacity(list.len());
                for (k, chunk) in list.chunks(SETTLE_CHUNK).enumerate() {
                    if cancel.is_cancelled() {
                        break;
                    }
                    match &q0 {
                        Starts::One(q) => rs.extend(self.motor.settle_many(chunk, q)),
                        Starts::PerSet(qs) => {
                            // each set's settle from its own start, as the library's
                            // settle_many settles each from the one start
                            use rayon::prelude::*;
                            let from = &qs[k * SETTLE_CHUNK..k * SETTLE_CHUNK + chunk.len()];
                            rs.par_extend(
                                chunk
                                    .par_iter()
                                    .zip(from.par_iter())
                                    .map(|(set, q)| self.motor.settle(set, q)),
                            );
                        }
                    }
                }
                let holding: Vec<_> = list
                    .iter()
                    .zip(&rs)
                    .map(|(set, r)| Holding::of(&sc.torques, set, &r.q))
                    .collect();
                (rs, holding)
            };
            match &pool {
                Some(p) => p.install(work),
                None => work(),
            }
        })?;
        SettleTable::new(py, list, rs, holding, self.sc.stator.len())
    }

    /// Plans a motion: which coil pairs to switch, in which order, to turn the ball by `angle`
    /// degrees about `axis` (world frame). Every argument left out is the scenario's `[plan]`
    /// setting; they are those of `spherestep plan`: `scheme` (min-axis-error, max-angle,
    /// weighted, search), `model` (pivot, dynamic, coils), `pairs` (K, or "2-K"), `start`
    /// (the orientation before the initial commutation), `to` (a target orientation instead
    /// of `axis` and `angle`).
    #[pyo3(signature = (axis = None, angle = None, *, scheme = None, model = None, pairs = None, start = None, to = None))]
    #[allow(clippy::too_many_arguments)]
    fn plan(
        &self,
        py: Python<'_>,
        axis: Option<&Bound<'_, PyAny>>,
        angle: Option<f64>,
        scheme: Option<&str>,
        model: Option<&str>,
        pairs: Option<&Bound<'_, PyAny>>,
        start: Option<&Bound<'_, PyAny>>,
        to: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Plan> {
        let changes = plan_changes(axis, angle, scheme, model, pairs, start, to)?;
        let settings = self
            .sc
            .plan_with(&changes, &ARGUMENT_NAMES)
            .map_err(lib_err)?;
        let motor = cancellable(&self.motor);
        let plan = interruptible(py, &motor.cancel, || motor.plan(&settings))?;
        Ok(Plan {
            plan,
            settings,
            sc: self.sc.clone(),
        })
    }

    /// Replays a plan (a `Plan`, or the path of a plan file) through the dynamics: where the
    /// ball really settles at each step, in this motor's physics or in `plant`'s (a motor with
    /// the same packings: the model error of a plan made for one physics and run on another).
    /// A `Simulation`; with `closed_loop=True` the plan played closed loop on `plant` (default:
    /// this motor) as `spherestep simulate PLAN SCENARIO --plant PLANT --closed-loop` does,
    /// aimed at the plan's last orientation and replanning in this motor's physics (with the
    /// step model `model`, default the scenario's) from a simulated sensor: a `Run`, the
    /// options those of `run`.
    #[pyo3(signature = (plan, plant = None, *, closed_loop = false, model = None, sensor_noise_deg = 0.0, seed = None, max_steps = None, identify = true))]
    #[allow(clippy::too_many_arguments)]
    fn simulate<'py>(
        &self,
        py: Python<'py>,
        plan: &Bound<'py, PyAny>,
        plant: Option<PyRef<'py, Motor>>,
        closed_loop: bool,
        model: Option<&str>,
        sensor_noise_deg: f64,
        seed: Option<i128>,
        max_steps: Option<i64>,
        identify: bool,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (seed, max_steps) = loop_numbers(seed, max_steps)?;
        let rows = rows_of(&self.sc, plan)?;
        let physics = self.physics(plant.as_deref())?;
        // the options checked before anything is computed, as the command line does
        let o = loop_options(closed_loop, sensor_noise_deg, seed, max_steps, identify)?;
        if !closed_loop {
            if model.is_some() {
                return Err(arg_err(
                    "model",
                    "closed_loop=True with model (the model of the replans; the open loop \
                     plays the plan as it is)",
                ));
            }
            let sim = py.detach(|| physics.motor.simulate(&rows));
            return Simulation { rows: sim }.into_bound_py_any(py);
        }
        let changes = PlanChanges {
            model,
            ..PlanChanges::default()
        };
        let settings = self
            .sc
            .plan_with(&changes, &ARGUMENT_NAMES)
            .map_err(lib_err)?;
        let lp = LoopPlan::of_rows(&settings, rows, RowsFrom::Argument("plan")).map_err(lib_err)?;
        let planned_steps = lp.planned_steps();
        let cl = o
            .settings(planned_steps, &LOOP_ARGUMENT_NAMES)
            .map_err(lib_err)?;
        let model = cancellable(&self.motor);
        let plant = spherestep::Motor {
            cancel: model.cancel.clone(),
            ..physics.motor.clone()
        };
        let run = interruptible(py, &model.cancel, || {
            model.run(&plant, &lp.settings, &lp.plan, lp.goal, &cl)
        })?;
        Run {
            run,
            closed_loop: true,
            sensor_noise_deg,
            seed: seed.unwrap_or(DEFAULT_SEED),
            planned_steps,
            coils: self.sc.stator.len(),
        }
        .into_bound_py_any(py)
    }

    /// The pairs `(coil, magnet)` whose magnet lies within `reach_deg` degrees of its coil at
    /// the orientation `q` (`[qx, qy, qz, qw]`, default identity), in coil then magnet order:
    /// the pairs a set may use there. `reach_deg` defaults to the coil's reach, the well's
    /// maximum attraction distance (what `settle` counts as holding).
    #[pyo3(signature = (reach_deg = None, q = None))]
    fn pairs_within(
        &self,
        reach_deg: Option<f64>,
        q: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Vec<(usize, usize)>> {
        let reach = match reach_deg {
            None => self.sc.torques.well.max_attraction().0,
            Some(d) if d.is_finite() && (0.0..=180.0).contains(&d) => d.to_radians(),
            Some(d) => {
                return Err(arg_err(
                    "reach_deg",
                    format!("an angle in [0, 180] degrees, got {d}"),
                ))
            }
        };
        let q = convert::orientation_or_identity(q, "q")?;
        let r = q.to_rotation_matrix();
        let t = &self.sc.torques;
        let mut out = Vec::new();
        for coil in 0..t.stator.len() {
            for magnet in 0..t.rotor.len() {
                if pair_gap(t, &r, spherestep::Pair::new(coil, magnet)).0 <= reach {
                    out.push((coil, magnet));
                }
            }
        }
        Ok(out)
    }

    /// The motor's well as a bench would measure it (`spherestep wells`): the torque on one
    /// magnet passing one energised coil every `step_deg` degrees (default 0.02, the command
    /// line's) from 0 to the cut-off.
    #[pyo3(signature = (step_deg = None))]
    fn wells(&self, step_deg: Option<f64>) -> PyResult<Wells> {
        let step_deg = step_deg.unwrap_or(spherestep::physics::well_curve::DEFAULT_STEP_DEG);
        let (curve, summary) = self.motor.wells(step_deg).map_err(lib_err)?;
        Ok(Wells { curve, summary })
    }

    /// Plans a motion in this motor's physics (the model) and plays it on `plant` (default:
    /// this motor), as `spherestep run` does: open loop, or with `closed_loop=True` on a
    /// simulated orientation sensor (noise `sensor_noise_deg`, seeded by `seed`), replanning
    /// the rest of the motion from each measurement that strays from the plan, at most
    /// `max_steps` steps, fitting the wells to the measurements unless `identify=False`. The
    /// plan's arguments are `plan`'s.
    #[pyo3(signature = (plant = None, axis = None, angle = None, *, scheme = None, model = None, pairs = None, start = None, to = None, closed_loop = false, sensor_noise_deg = 0.0, seed = None, max_steps = None, identify = true))]
    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        py: Python<'_>,
        plant: Option<PyRef<'_, Motor>>,
        axis: Option<&Bound<'_, PyAny>>,
        angle: Option<f64>,
        scheme: Option<&str>,
        model: Option<&str>,
        pairs: Option<&Bound<'_, PyAny>>,
        start: Option<&Bound<'_, PyAny>>,
        to: Option<&Bound<'_, PyAny>>,
        closed_loop: bool,
        sensor_noise_deg: f64,
        seed: Option<i128>,
        max_steps: Option<i64>,
        identify: bool,
    ) -> PyResult<Run> {
        let (seed, max_steps) = loop_numbers(seed, max_steps)?;
        let physics = self.physics(plant.as_deref())?;
        let changes = plan_changes(axis, angle, scheme, model, pairs, start, to)?;
        let settings = self
            .sc
            .plan_with(&changes, &ARGUMENT_NAMES)
            .map_err(lib_err)?;
        // The options checked before anything is computed, as the command line does.
        let o = loop_options(closed_loop, sensor_noise_deg, seed, max_steps, identify)?;
        let (model, plant) = (cancellable(&self.motor), physics.motor.clone());
        let plant = spherestep::Motor {
            cancel: model.cancel.clone(),
            ..plant
        };
        let p = interruptible(py, &model.cancel, || model.plan(&settings))?;
        let lp = LoopPlan::planned(&settings, p, &LOOP_ARGUMENT_NAMES).map_err(lib_err)?;
        let planned_steps = lp.planned_steps();
        let cl = o
            .settings(planned_steps, &LOOP_ARGUMENT_NAMES)
            .map_err(lib_err)?;
        let run = interruptible(py, &model.cancel, || {
            model.run(&plant, &lp.settings, &lp.plan, lp.goal, &cl)
        })?;
        Ok(Run {
            run,
            closed_loop,
            sensor_noise_deg,
            seed: seed.unwrap_or(DEFAULT_SEED),
            planned_steps,
            coils: self.sc.stator.len(),
        })
    }

    /// The number of the rotor's magnets.
    #[getter]
    fn magnets(&self) -> usize {
        self.sc.rotor.len()
    }

    /// The number of the stator's coils.
    #[getter]
    fn coils(&self) -> usize {
        self.sc.stator.len()
    }

    /// The scenario this motor was made from.
    #[getter]
    fn scenario(&self) -> Scenario {
        self.scenario.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "Motor(scenario={:?}, magnets={}, coils={})",
            self.sc.name,
            self.sc.rotor.len(),
            self.sc.stator.len()
        )
    }
}
