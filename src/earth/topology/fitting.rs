//! A coverage's arcs fitted: every arc fitted once ([`fit_arc`]), then, for validity, arcs
//! of one polygon (exterior and holes) or meeting at a junction that cross each other (or an
//! arc itself) where the input did not are refitted at half their tolerance, up to
//! [`TIGHTEN_ROUNDS`] times.

use super::*;

/// The arcs of a coverage, fitted.
pub(super) struct FittedArcs {
    /// The fitted arcs (index = arc index).
    pub(super) arcs: Vec<FittedArc>,
    /// How many arcs were fitted to a tighter tolerance than the job's.
    pub(super) tightened: usize,
    /// The pairs of arcs that still cross after [`TIGHTEN_ROUNDS`].
    pub(super) crossings_left: Vec<(usize, usize)>,
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
        fit_arc(
            &self.input_arcs[a],
            self.graph.arcs[a].closed,
            tolerance,
            self.degree_cap,
            self.parameterization,
            self.job,
        )
        .map_err(|e| EarthError::new(pointer.clone(), e.problem))
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
    tighten(&fitting, fitted, tolerance)
}

/// Refits the arcs that cross where their input did not at half their tolerance, up to
/// [`TIGHTEN_ROUNDS`] times; a refit arc meets the tolerance when it is within the job's.
fn tighten(
    fitting: &ArcFitting<'_>,
    mut fitted: Vec<FittedArc>,
    tolerance: ToleranceRule,
) -> Result<FittedArcs, EarthError> {
    let (graph, input_arcs) = (fitting.graph, &fitting.input_arcs);
    // Rings by polygon (exterior and holes), so holes are checked against their shell too.
    let mut polygon_rings: std::collections::BTreeMap<(usize, usize), Vec<usize>> =
        Default::default();
    for (ri, src) in fitting.sources.iter().enumerate() {
        polygon_rings
            .entry((src.feature, src.polygon))
            .or_default()
            .push(ri);
    }
    let groups: Vec<Vec<usize>> = polygon_rings.into_values().collect();
    let pairs = arc_pairs(graph, &groups);
    let input_crossing: HashSet<(usize, usize)> = pairs
        .par_iter()
        .filter(|&&(a, b)| polylines_cross(&input_arcs[a], &input_arcs[b], a == b))
        .copied()
        .collect();
    let mut arc_tol = vec![tolerance; graph.arcs.len()];
    let mut crossings_left = Vec::new();
    for round in 0..=TIGHTEN_ROUNDS {
        let crossing: Vec<(usize, usize)> = pairs
            .par_iter()
            .filter(|p| !input_crossing.contains(p))
            .filter(|&&(a, b)| polylines_cross(&fitted[a].dense, &fitted[b].dense, a == b))
            .copied()
            .collect();
        if crossing.is_empty() || round == TIGHTEN_ROUNDS {
            crossings_left = crossing;
            break;
        }
        let mut redo: Vec<usize> = crossing.iter().flat_map(|&(a, b)| [a, b]).collect();
        redo.sort_unstable();
        redo.dedup();
        let refits = fitting.fit_many(&redo, |a| arc_tol[a].halved())?;
        for (a, f) in redo.into_iter().zip(refits) {
            arc_tol[a] = arc_tol[a].halved();
            fitted[a] = FittedArc {
                tolerance_met: tolerance_met_by(&f, &tolerance),
                ..f
            };
        }
    }
    for (a, f) in fitted.iter_mut().enumerate() {
        f.tolerance_rad = arc_tol[a].tol_rad;
    }
    Ok(FittedArcs {
        arcs: fitted,
        tightened: arc_tol
            .iter()
            .filter(|t| t.tol_rad < tolerance.tol_rad)
            .count(),
        crossings_left,
    })
}

/// The pairs of arcs (a <= b; (a, a) for an arc and itself) that could cross in a way that
/// matters: arcs of one polygon (its exterior and holes: `groups` lists each polygon's rings),
/// and arcs ending at one junction.
fn arc_pairs(graph: &ArcGraph, groups: &[Vec<usize>]) -> Vec<(usize, usize)> {
    let mut pairs = BTreeSet::new();
    let mut at_vertex: std::collections::HashMap<usize, Vec<usize>> = Default::default();
    for (a, arc) in graph.arcs.iter().enumerate() {
        pairs.insert((a, a));
        if !arc.closed {
            for v in [arc.vertices[0], arc.vertices[arc.vertices.len() - 1]] {
                at_vertex.entry(v).or_default().push(a);
            }
        }
    }
    let mut add_all = |arcs: &[usize]| {
        for (i, &a) in arcs.iter().enumerate() {
            for &b in &arcs[i..] {
                pairs.insert((a.min(b), a.max(b)));
            }
        }
    };
    for rings in groups {
        let mut arcs: Vec<usize> = rings
            .iter()
            .flat_map(|&r| graph.rings[r].iter().map(|u| u.arc))
            .collect();
        arcs.sort_unstable();
        arcs.dedup();
        add_all(&arcs);
    }
    for arcs in at_vertex.values() {
        add_all(arcs);
    }
    pairs.into_iter().collect()
}
