//! A coverage's arcs fitted: every arc fitted once ([`fit_arc`]), then, for validity, arcs
//! of one feature or meeting at a junction that meet each other (or an arc itself) where the
//! input did not, on the sphere or as written, are refitted tighter, up to [`validity::REFIT_ROUNDS`]
//! times ([`crate::earth::polygon::validity`]).

use crate::earth::coverage::arcs::ArcGraph;
use crate::earth::coverage::fit_arc::{keep_arc, refit_around, tolerance_met_by};
use crate::earth::coverage::phases::Phases;
use crate::earth::coverage::read::RingSource;
use crate::earth::coverage::rebuild::ring_lonlat;
use crate::earth::coverage::{fit_arc, FittedArc};
use crate::earth::curve::tolerance_rule::ToleranceRule;
use crate::earth::error::{EarthError, Problem};
use crate::earth::job::Job;
use crate::earth::lonlat::m_to_rad;
use crate::earth::polygon::small_rings;
use crate::earth::polygon::validity::{self, Drawn, Tightened};
use rayon::prelude::{IntoParallelRefIterator, ParallelIterator};

/// The arcs of a coverage, fitted.
pub(super) struct FittedArcs {
    /// The fitted arcs (index = arc index).
    pub(super) arcs: Vec<FittedArc>,
    /// How many arcs were fitted to a tighter tolerance than the job's.
    pub(super) tightened: usize,
    /// The pairs of arcs that still meet after [`validity::REFIT_ROUNDS`].
    pub(super) crossings_left: Vec<(usize, usize)>,
    /// Decimal steps in a step of the grid every arc lies on: the rule's, or 1 when arcs fitted
    /// on a coarser grid still met and were refitted on the decimal one.
    pub(super) grid_multiple: u32,
}

/// What fitting one arc of a coverage needs: the arcs, where they came from, and the job.
struct ArcFitting<'a> {
    graph: &'a ArcGraph,
    sources: &'a [RingSource],
    /// The first ring using each arc, for error pointers.
    arc_ring: Vec<usize>,
    /// Each arc's input positions.
    input_arcs: Vec<Vec<[f64; 3]>>,
    /// The degrees tried: 1 to this.
    degree_cap: usize,
    parameterization: crate::sphere::Parameterization,
    job: &'a Job,
}

impl ArcFitting<'_> {
    /// Fits arc `a` to `tolerance`; errors point at the first ring using it.
    fn fit(&self, a: usize, tolerance: ToleranceRule) -> Result<FittedArc, EarthError> {
        let _scope = self.job.cancel.enter();
        let pointer = &self.sources[self.arc_ring[a]].pointer;
        self.job
            .cancel
            .check()
            .map_err(|e| EarthError::new(pointer.clone(), Problem::Fit(e)))?;
        let points = &self.input_arcs[a];
        let closed = self.graph.arcs[a].closed;
        let at = |e: EarthError| EarthError::new(pointer.clone(), e.problem);
        let fitted = fit_arc(
            points,
            closed,
            tolerance,
            self.degree_cap,
            self.parameterization,
            self.job,
        )
        .map_err(at)?;
        // A whole ring whose fit bounds no area is kept as an arc ([`keep_arc`]), unless such
        // rings are to be dropped (then it is dropped when its feature is rebuilt).
        if closed && !self.job.drop_small_rings && small_rings::collapsed_lonlat(&fitted.dense_ll) {
            if let Some(kept) = keep_arc(points, tolerance, self.job).map_err(at)? {
                return Ok(kept);
            }
        }
        Ok(fitted)
    }

    /// Arc `a` (fitted as `old`) refitted to `tolerance` around its segments `at` only
    /// ([`refit_around`]), when that can be done and the arc then meets `job_tolerance`.
    ///
    /// The windows refitted grow as the tolerance falls, round by round: a meeting that a
    /// window pinned at the old vertices next to it did not part may need more room (T/2: one
    /// vertex each side, T/4: two, T/16: four, T/64: six). The first round at
    /// [`validity::LAST_RESORT_M`] splices the input itself in, with wide windows; the last
    /// refits the whole arc, as close to its input as it is written, so the output is valid
    /// wherever the input is.
    fn refit_around(
        &self,
        a: usize,
        old: &FittedArc,
        at: &[usize],
        tolerance: ToleranceRule,
        job_tolerance: &ToleranceRule,
    ) -> Result<Option<FittedArc>, EarthError> {
        // A ring kept small is kept again, tighter, whole.
        if old.tolerance_rad <= m_to_rad(validity::LAST_RESORT_M) || old.small_ring.is_some() {
            return Ok(None);
        }
        let _scope = self.job.cancel.enter();
        let pointer = &self.sources[self.arc_ring[a]].pointer;
        validity::splice_around(
            (&old.dense, at),
            (
                job_tolerance.tolerance_m,
                tolerance.tolerance_m,
                self.job.output.precision,
            ),
            |f: &FittedArc| f.dense.as_slice(),
            |at, margin| {
                refit_around(
                    &self.input_arcs[a],
                    self.graph.arcs[a].closed,
                    old,
                    (at, margin),
                    tolerance,
                    self.parameterization,
                    self.job,
                )
                .map_err(|e| EarthError::new(pointer.clone(), e.problem))
            },
            |f| tolerance_met_by(f, job_tolerance),
        )
    }

    /// Fits the arcs `which` in parallel, each to its tolerance; the first error in order wins.
    fn fit_many(
        &self,
        which: &[usize],
        tolerance: impl Fn(usize) -> ToleranceRule + Sync,
    ) -> Result<Vec<FittedArc>, EarthError> {
        which
            .par_iter()
            .map(|&a| self.fit(a, tolerance(a)))
            .collect::<Vec<_>>()
            .into_iter()
            .collect()
    }
}

/// Fits every arc of `graph` to `tolerance` and tightens the arcs that cross (see the module
/// docs). `sources` says where each ring came from.
pub(super) fn fit_arcs(
    graph: &ArcGraph,
    sources: &[RingSource],
    tolerance: ToleranceRule,
    options: &crate::sphere::FitOptions,
    job: &Job,
    phases: &mut Phases,
) -> Result<FittedArcs, EarthError> {
    let mut arc_ring = vec![usize::MAX; graph.arcs.len()];
    for (ri, uses) in graph.rings.iter().enumerate() {
        for u in uses {
            if arc_ring[u.arc] == usize::MAX {
                arc_ring[u.arc] = ri;
            }
        }
    }
    let fitting = ArcFitting {
        graph,
        sources,
        arc_ring,
        input_arcs: (0..graph.arcs.len()).map(|a| graph.arc_points(a)).collect(),
        degree_cap: options.degree.max(1),
        parameterization: options.parameterization,
        job,
    };
    let all: Vec<usize> = (0..graph.arcs.len()).collect();
    let fitted = fitting.fit_many(&all, |_| tolerance)?;
    phases.lap("fit arcs");
    let tightened = tighten(&fitting, fitted, tolerance);
    phases.lap("crossings");
    tightened
}

/// Refits the arcs that meet where their input did not ([`crate::earth::polygon::validity::tighten`]),
/// up to [`validity::REFIT_ROUNDS`] times; a refit arc meets the tolerance when it is within the job's.
fn tighten(
    fitting: &ArcFitting<'_>,
    mut fitted: Vec<FittedArc>,
    tolerance: ToleranceRule,
) -> Result<FittedArcs, EarthError> {
    let (graph, input_arcs) = (fitting.graph, &fitting.input_arcs);
    let opened = open_collapsed_rings(fitting, &mut fitted, tolerance)?;
    // Judged as written at the output's precision, as per feature.
    let input = Drawn::new(
        input_arcs.iter().map(Vec::as_slice).collect(),
        Some(fitting.job.output.precision),
    );
    let pairs = arc_pairs(graph, &input, 2.0 * tolerance.tol_rad);
    let run = |fitted: &mut Vec<FittedArc>, grid_multiple: u32| {
        validity::tighten(
            &input,
            &pairs,
            tolerance.tolerance_m,
            validity::REFIT_ROUNDS,
            fitted,
            |f: &FittedArc| f.dense.as_slice(),
            |a, t, old: &FittedArc, at: &[usize]| {
                // No looser than a collapsed ring's arcs were opened at (else it closes again).
                let t = t.min(opened[a]);
                let rule =
                    ToleranceRule::new(t, tolerance.precision).with_grid_multiple(grid_multiple);
                if let Some(f) = fitting.refit_around(a, old, at, rule, &tolerance)? {
                    return Ok(Some(FittedArc {
                        tolerance_met: true,
                        ..f
                    }));
                }
                let f = fitting.fit(a, rule)?;
                Ok::<_, EarthError>(Some(FittedArc {
                    tolerance_met: tolerance_met_by(&f, &tolerance),
                    ..f
                }))
            },
        )
    };
    let Tightened {
        mut tolerance_m,
        left: mut crossings_left,
    } = run(&mut fitted, tolerance.grid_multiple)?;
    for (t, o) in tolerance_m.iter_mut().zip(&opened) {
        *t = t.min(*o);
    }
    let mut grid_multiple = tolerance.grid_multiple;
    if !crossings_left.is_empty() && grid_multiple > 1 {
        // A coarse grid can draw a small ring's own input meeting itself where the decimal
        // grid draws it apart (10m countries at 1 km on 0.004 degrees: five islands). Every
        // arc fitted on the coarse grid lies on the decimal one too, so only the arcs still
        // meeting are refitted tighter on it, and the coverage is written on it.
        grid_multiple = 1;
        let again = run(&mut fitted, grid_multiple)?;
        for (t, u) in tolerance_m.iter_mut().zip(again.tolerance_m) {
            *t = t.min(u);
        }
        crossings_left = again.left;
    }
    for (a, f) in fitted.iter_mut().enumerate() {
        f.tolerance_rad = m_to_rad(tolerance_m[a]);
    }
    Ok(FittedArcs {
        arcs: fitted,
        tightened: tolerance_m
            .iter()
            .filter(|&&t| t < tolerance.tolerance_m)
            .count(),
        crossings_left,
        grid_multiple,
    })
}

/// Rings whose fitted outline bounds no area (a small enclave with a land border, whose arcs
/// fit as one straight segment between the same two junctions, or a ring of one arc from a
/// junction back to it) have their arcs refitted at half the tolerance, up to
/// [`OPEN_ROUNDS`] times, until it does (an island is kept as an arc first: `keep_arc`); each arc's
/// tolerance (metres) is returned. Kept apart from the arcs, as such a ring was until
/// 2026-12-06, its triangle of input positions overlapped its neighbour, whose side of the
/// border is the shared arc: at 5 km Melilla overlapped Morocco, and Dhekelia Cyprus. With
/// `drop_small_rings`, they are left to be dropped.
fn open_collapsed_rings(
    fitting: &ArcFitting<'_>,
    fitted: &mut [FittedArc],
    tolerance: ToleranceRule,
) -> Result<Vec<f64>, EarthError> {
    let graph = fitting.graph;
    let mut tolerance_m = vec![tolerance.tolerance_m; fitted.len()];
    if fitting.job.drop_small_rings {
        return Ok(tolerance_m);
    }
    for _ in 0..OPEN_ROUNDS {
        let mut arcs: Vec<usize> = graph
            .rings
            .iter()
            .filter(|uses| {
                !uses.is_empty() && small_rings::collapsed_lonlat(&ring_lonlat(uses, fitted))
            })
            .flat_map(|uses| uses.iter().map(|u| u.arc))
            .collect();
        arcs.sort_unstable();
        arcs.dedup();
        if arcs.is_empty() {
            break;
        }
        let refits = fitting.fit_many(&arcs, |a| {
            ToleranceRule::new(0.5 * tolerance_m[a], tolerance.precision)
                .with_grid_multiple(tolerance.grid_multiple)
        })?;
        for (&a, f) in arcs.iter().zip(refits) {
            tolerance_m[a] *= 0.5;
            fitted[a] = FittedArc {
                tolerance_met: tolerance_met_by(&f, &tolerance),
                ..f
            };
        }
    }
    Ok(tolerance_m)
}

/// How many times [`open_collapsed_rings`] halves the tolerance of a collapsed ring's arcs
/// (to T/64); a ring still collapsed is then kept apart from the arcs.
const OPEN_ROUNDS: usize = 6;

/// The pairs of arcs (a <= b; (a, a) for an arc and itself) that could meet in a way that
/// matters: any two arcs of the coverage whose boxes come within `grow` of each other
/// ([`Drawn::near_pairs`]), whichever features use them.
///
/// In a coverage an arc crossing another is an error wherever it is: until 2026-12-06 only
/// arcs of one feature (and at one junction) were paired, and at 5 km the 10m countries came
/// back with six pairs of neighbours overlapping where their input did not (Singapore over
/// Malaysia's coast across the Johor Strait, Spain's islets off Morocco, the features of
/// Cyprus).
fn arc_pairs(graph: &ArcGraph, drawn: &Drawn<'_>, grow: f64) -> Vec<(usize, usize)> {
    // Arcs ending at one junction are among them: their boxes share the junction.
    let all: Vec<usize> = (0..graph.arcs.len()).collect();
    drawn.near_pairs(&all, grow)
}
