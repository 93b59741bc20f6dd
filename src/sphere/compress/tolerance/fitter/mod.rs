//! The working curve of one degree's fit ([`Fitter`]): knots, control points, data parameters
//! and every point's error, with the moves the fitter makes on them, each in its own file:
//! foot-point correction (`foot_points`), Gauss–Newton refits of a window of control points
//! (`refit`), knot insertion where the error is too large (`insertion`) and greedy knot removal
//! (`removal`).

mod foot_points;
mod insertion;
mod refit;
mod removal;

pub(super) use refit::Stale;

use crate::sphere::compress::simplify::{douglas_peucker, douglas_peucker_ordered};
use crate::sphere::compress::tolerance::{Curve, KnotRule, Line, ToleranceOptions};
use crate::sphere::curve::bspline::{
    clamped_uniform_knots, Degree, Frame, Scratch, SphericalBSpline,
};
use crate::sphere::fit::knots::greville_control_points;
use crate::sphere::geometry::point::{angle, Arc, Dim, PointSet};
use crate::sphere::linalg::banded::{BandCholesky, SymmetricBand};

/// Gauss–Newton passes per (local) refit (a knot removal's refit takes fewer, see
/// `removal`). The fits start close to their optimum (after a knot
/// insertion or removal only a few control points move), and the tolerance test, not the
/// optimum, decides.
pub(super) const REFIT_ITERATIONS: usize = 6;

/// The working state of one degree's fit: knots, control points, data parameters and the error
/// of every point, with local refits on windows of control points.
pub(super) struct Fitter<'a, D: Dim, G: Degree> {
    d: D,
    g: G,
    points: &'a PointSet,
    free: bool,
    /// Use Lawson reweighting in removals.
    pub(super) reweight: bool,
    /// The end control points are the first and last point and never move.
    pinned: bool,
    params: Vec<f64>,
    knots: Vec<f64>,
    ctrl: PointSet,
    err: Vec<f64>,
    /// Least-squares weight of each point: 1, raised around points that stay out of tolerance
    /// while a removal is tried (Lawson-style reweighting towards the minimax fit).
    weight: Vec<f64>,
    eval: Evaluator,
    c: Vec<f64>,
    c2: Vec<f64>,
    /// Kept between refits: a removal sweep refits thousands of small windows.
    buffers: RefitBuffers,
    /// What a removal saves to undo itself, kept between removals.
    undo: Undo,
}

/// What consecutive evaluations of the working curve share: the de Boor
/// scratch (with the contribution coefficients of the last evaluation) and the span of the last
/// evaluation ([`Fitter::eval_into`]).
struct Evaluator {
    scratch: Scratch,
    span_hint: usize,
    /// Degree 1: the arc of the last evaluation and its two end points (`2 × dim` values).
    /// The passes go through a span's points in order, so most evaluations reuse it.
    arc: Option<Arc>,
    arc_ends: Vec<f64>,
}

impl Evaluator {
    fn new(p: usize, dim: usize) -> Evaluator {
        Evaluator {
            scratch: Scratch::new(p, dim),
            span_hint: p,
            arc: None,
            arc_ends: vec![0.0; 2 * dim],
        }
    }

    /// The arc from `a` to `b` for [`Frame::eval_linear`]: the last one while its end points
    /// are the same values (it was a sixth of a polyline removal's time), else computed and
    /// kept.
    #[inline(always)]
    fn arc_of<D: Dim>(&mut self, d: D, a: &[f64], b: &[f64]) -> Arc {
        let dim = d.get();
        match self.arc {
            Some(arc) if self.arc_ends[..dim] == a[..dim] && self.arc_ends[dim..] == b[..dim] => {
                arc
            }
            _ => {
                let arc = Arc::between(d, a, b);
                self.arc_ends[..dim].copy_from_slice(&a[..dim]);
                self.arc_ends[dim..].copy_from_slice(&b[..dim]);
                self.arc = Some(arc);
                arc
            }
        }
    }
}

/// The window a knot removal changes, saved before its refit ([`Fitter::try_remove`]).
#[derive(Default)]
struct Undo {
    removed: Vec<f64>,
    ctrl: Vec<f64>,
    params: Vec<f64>,
    err: Vec<f64>,
}

/// The working arrays of one Gauss–Newton refit ([`Fitter::refit_from`]).
#[derive(Default)]
struct RefitBuffers {
    band: SymmetricBand,
    chol: BandCholesky,
    rhs: Vec<f64>,
    step: Vec<f64>,
    saved: Vec<f64>,
    /// The window's parameters before a polyline step (which moves them to foot points).
    saved_params: Vec<f64>,
}

impl<'a, D: Dim, G: Degree> Fitter<'a, D, G> {
    /// C(t) into `self.c` (`self.c2` with `second`); with `CONTRIB` the contribution
    /// coefficients are in `self.eval.scratch.contrib`. Returns the span, and keeps it in
    /// `self.eval.span_hint`: the fitter's passes go through the points in order, so the next
    /// span is this one or the next and no binary search over the knots is needed.
    #[inline(always)]
    fn eval_into<const CONTRIB: bool>(&mut self, t: f64, second: bool) -> usize {
        let frame = Frame::new(self.g.get(), &self.knots, &self.ctrl);
        let k = frame.span_from(self.eval.span_hint.clamp(frame.p, frame.last_span), t);
        self.eval.span_hint = k;
        let out = if second { &mut self.c2 } else { &mut self.c };
        if self.g.get() == 1 {
            let arc = self
                .eval
                .arc_of(self.d, self.ctrl.get(k - 1), self.ctrl.get(k));
            frame.eval_linear::<D, CONTRIB>(self.d, k, t, &arc, &mut self.eval.scratch, out);
            return k;
        }
        frame.eval::<D, G, CONTRIB, false>(self.d, self.g, k, t, &mut self.eval.scratch, out);
        k
    }

    /// C(t) into `self.c`; the span.
    #[inline(always)]
    fn eval(&mut self, t: f64) -> usize {
        self.eval_into::<false>(t, false)
    }

    /// The working curve `knots`, `ctrl` for `points` at data parameters `params` (moving to
    /// foot points when `free`), every error 0 until [`measured`](Self::measured) or the
    /// caller sets them.
    fn unmeasured(
        d: D,
        g: G,
        points: &'a PointSet,
        free: bool,
        params: Vec<f64>,
        knots: Vec<f64>,
        ctrl: PointSet,
    ) -> Self {
        let (p, dim, n) = (g.get(), d.get(), points.len());
        Fitter {
            d,
            g,
            points,
            free,
            reweight: false,
            pinned: false,
            err: vec![0.0; n],
            weight: vec![1.0; n],
            params,
            knots,
            ctrl,
            eval: Evaluator::new(p, dim),
            c: vec![0.0; dim],
            c2: vec![0.0; dim],
            buffers: RefitBuffers::default(),
            undo: Undo::default(),
        }
    }

    /// Every point's error measured.
    fn measured(mut self) -> Self {
        self.measure_range(0, self.points.len());
        self
    }

    /// The curve on `knots` through the Greville control points of `line` (at `line.params`).
    pub(super) fn with_knots(d: D, g: G, line: Line<'a>, knots: Vec<f64>) -> Option<Self> {
        let ctrl = greville_control_points(line.points, line.params, &knots, g.get()).ok()?;
        let (points, free, params) = (line.points, line.free, line.params.to_vec());
        Some(Fitter::unmeasured(d, g, points, free, params, knots, ctrl).measured())
    }

    /// The first curve: for degree 1 the Douglas–Peucker polyline at the tolerance itself (which
    /// meets it once parameters are foot points); for higher degrees knots at the vertices of a
    /// coarser Douglas–Peucker, the curve then fitted.
    pub(super) fn seeded(
        d: D,
        g: G,
        line: Line<'a>,
        target: f64,
        cap: usize,
        options: &ToleranceOptions,
    ) -> Option<Self> {
        let p = g.get();
        let factor = if p == 1 { 1.0 } else { options.seed_factor };
        // The polyline seed keeps the points in order along its chords (fjords, spikes), so it
        // meets the target once parameters are foot points, without knot insertions.
        let kept = if p == 1 {
            douglas_peucker_ordered(line.points, target)
        } else {
            douglas_peucker(line.points, target * factor)
        };
        Self::from_kept(d, g, line, &kept, cap, options)
    }

    /// [`seeded`](Self::seeded) from the vertices `kept` (ascending, the first and the last
    /// point among them) of a Douglas–Peucker polyline already computed.
    pub(super) fn from_kept(
        d: D,
        g: G,
        line: Line<'a>,
        kept: &[usize],
        cap: usize,
        options: &ToleranceOptions,
    ) -> Option<Self> {
        let p = g.get();
        let last = line.points.len() - 1;
        let mut vertices = vec![0];
        let mut interior: Vec<f64> = Vec::with_capacity(kept.len());
        for &i in &kept[1..kept.len() - 1] {
            let u = line.params[i];
            if u > interior.last().copied().unwrap_or(0.0) && u < 1.0 {
                interior.push(u);
                vertices.push(i);
            }
        }
        vertices.push(last);
        let mut f = if vertices.len() + p - 1 > cap {
            // Too many for the cap: the cap's count of control points on uniform knots.
            Fitter::with_knots(d, g, line, clamped_uniform_knots(cap, p))?
        } else {
            let mut knots = vec![0.0; p + 1];
            knots.extend(interior);
            knots.extend(std::iter::repeat_n(1.0, p + 1));
            if p == 1 {
                // The polyline itself: control points at the kept vertices.
                let ctrl = line.points.subset(&vertices);
                let params = line.params.to_vec();
                Fitter::unmeasured(d, g, line.points, line.free, params, knots, ctrl).measured()
            } else {
                Fitter::with_knots(d, g, line, knots)?
            }
        };
        if options.pin_ends {
            f.pin_ends();
        }
        if line.free {
            f.correct_all(4);
        }
        Some(f)
    }

    /// Puts the end control points on the first and last point and keeps them there.
    pub(super) fn pin_ends(&mut self) {
        let (n, last) = (self.n_ctrl(), self.points.len() - 1);
        self.ctrl.get_mut(0).copy_from_slice(self.points.get(0));
        self.ctrl
            .get_mut(n - 1)
            .copy_from_slice(self.points.get(last));
        self.pinned = true;
        // Only the points read by the two end control points change (a seed from data points
        // has them there already): the others keep their errors.
        let (j0, j1) = self.window_points(0, 1);
        self.measure_range(j0, j1);
        let (j0, j1) = self.window_points(n - 1, n);
        self.measure_range(j0, j1);
    }

    fn p(&self) -> usize {
        self.g.get()
    }

    /// The line ends where it starts (a ring given as a line).
    fn closed(&self) -> bool {
        let n = self.points.len();
        n > 2 && self.points.get(0) == self.points.get(n - 1)
    }

    pub(super) fn n_ctrl(&self) -> usize {
        self.ctrl.len()
    }

    pub(super) fn max_error(&self) -> f64 {
        self.err.iter().fold(0.0, |a, &b| a.max(b))
    }

    /// The fitted spline; `None` when it is not a valid spline (two neighbouring control
    /// points (nearly) antipodal, as a fit along a great circle can make): that candidate is
    /// dropped rather than returned.
    pub(super) fn into_curve(self, rule: KnotRule) -> Option<Curve> {
        let spline = SphericalBSpline::try_new(self.p(), self.knots, self.ctrl).ok()?;
        Some(Curve {
            spline,
            params: self.params,
            rule,
            decided: None,
        })
    }

    fn last_span(&self) -> usize {
        let (p, n) = (self.p(), self.n_ctrl());
        (p..n)
            .rev()
            .find(|&k| self.knots[k] < self.knots[k + 1])
            .unwrap_or(p)
    }

    /// The data points whose curve point depends on control points `c0 .. c1`.
    fn window_points(&self, c0: usize, c1: usize) -> (usize, usize) {
        let p = self.p();
        let last = self.last_span();
        let kmin = c0.max(p);
        let kmax = (c1 + p - 1).min(last);
        if kmin > kmax {
            return (0, 0);
        }
        let lo = if kmin == p {
            f64::NEG_INFINITY
        } else {
            self.knots[kmin]
        };
        let hi = if kmax == last {
            f64::INFINITY
        } else {
            self.knots[kmax + 1]
        };
        let j0 = self.params.partition_point(|&t| t < lo);
        let j1 = self.params.partition_point(|&t| t < hi);
        (j0, j1)
    }

    fn error_at(&mut self, j: usize, t: f64) -> f64 {
        self.eval(t);
        angle(self.d, self.points.get(j), &self.c)
    }

    /// Measures points `j0 .. j1` into `err`; returns (max, sum of squares).
    fn measure_range(&mut self, j0: usize, j1: usize) -> (f64, f64) {
        let (mut max, mut sq): (f64, f64) = (0.0, 0.0);
        for j in j0..j1 {
            let e = self.error_at(j, self.params[j]);
            self.err[j] = e;
            max = max.max(e);
            sq += self.weight[j] * e * e;
        }
        (max, sq)
    }

    /// The same curve family with uniform knots (none stored). For degree 1 the polyline is
    /// unchanged (only its speed changes), so parameters are mapped span by span and the errors
    /// stay the same; for higher degrees the curve is refitted. `None` when the target is missed.
    pub(super) fn to_uniform(&self, target: f64) -> Option<Curve> {
        let p = self.p();
        let n = self.n_ctrl();
        let knots = clamped_uniform_knots(n, p);
        let last = self.last_span();
        // How many knots are at or before t: the parameters do not decrease, so it is found by
        // walking on from the last point's count (a binary search per point was 0.4 % of a
        // 10 m fit), and searched afresh should one ever go back.
        let mut at_or_before = 0;
        let mut prev = f64::NEG_INFINITY;
        let params: Vec<f64> = self
            .params
            .iter()
            .map(|&t| {
                if t < prev {
                    at_or_before = self.knots.partition_point(|&u| u <= t);
                }
                prev = t;
                while at_or_before < self.knots.len() && self.knots[at_or_before] <= t {
                    at_or_before += 1;
                }
                let k = at_or_before.saturating_sub(1).clamp(p, last);
                let (a, b) = (self.knots[k], self.knots[k + 1]);
                let f = if b > a {
                    ((t - a) / (b - a)).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                knots[k] + f * (knots[k + 1] - knots[k])
            })
            .collect();
        let ctrl = self.ctrl.clone();
        let mut f = if p == 1 {
            // The same polyline at the same points of its arcs: the errors are this curve's
            // (to rounding; the search measures the returned curve afresh anyway).
            let mut f = Fitter::unmeasured(self.d, self.g, self.points, true, params, knots, ctrl);
            f.err.copy_from_slice(&self.err);
            f
        } else {
            Fitter::unmeasured(self.d, self.g, self.points, true, params, knots, ctrl).measured()
        };
        f.pinned = self.pinned;
        let mut max = f.max_error();
        if max > target && p >= 2 {
            f.correct_all(4);
            // (The correction has measured every point.)
            let measured = Stale::Points(0, 0);
            max = f
                .refit_from(
                    0,
                    n,
                    3 * REFIT_ITERATIONS,
                    target,
                    f64::INFINITY,
                    false,
                    measured,
                )
                .max(f.max_error());
        }
        if max <= target {
            f.into_curve(KnotRule::Uniform)
        } else {
            None
        }
    }
}

/// A wave along the equator for the fitter's tests: `n` points `step` radians apart in
/// longitude, at latitude `amplitude · sin(frequency · longitude) + jitter(i)`.
#[cfg(test)]
fn test_wave(
    n: usize,
    step: f64,
    amplitude: f64,
    frequency: f64,
    jitter: impl Fn(usize) -> f64,
) -> PointSet {
    let rows: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let a = i as f64 * step;
            let lat = amplitude * (frequency * a).sin() + jitter(i);
            [lat.cos() * a.cos(), lat.cos() * a.sin(), lat.sin()]
        })
        .collect();
    PointSet::try_from_rows(&rows).unwrap()
}
