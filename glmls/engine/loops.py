"""What a driver that caps an invocation's loop iterations lets one evaluation of f walk.

Mesa's llvmpipe stops all the loops of a shader invocation after 65,535 iterations counted over
all of them, for a vector of eight lanes together, and goes on as if they had ended: f would
leave handles out without a word (:attr:`glmls.gl.GLContext.loop_limit`). An evaluation that
visits every handle walks them sixteen a loop iteration, the same loops for every lane
(:func:`plain_loops`): a count that fits is refused no further. One through spatial bins walks
the handles of the bins near its point, one an iteration
(:meth:`glmls.engine.bins.HandleBins.evaluation_loops`): few where the handles spread, many
where thousands crowd a few bins, and lanes that walk apart add up. So:

- bins whose walk (one lane's) could exceed the cap give way to visiting every handle (or,
  asked for, are refused): :func:`bins_serve`;
- the points pass marks an evaluation the cap cut short (``common/loops.glsl``,
  ``mls/points.comp.glsl``); at a list of points the host evaluates those again, each alone in
  its vector of lanes, and refuses what still does not fit; on a lattice, whose lanes are
  neighbours, it checks where eight lanes apart could exceed the cap (:func:`walks_checked`);
- the Newton passes keep only the evaluations the cap left whole and go on in a second
  dispatch, visit every handle where the bins would cut them shorter
  (:func:`newton_visits_all`), and are refused where not one Newton step fits
  (:func:`check_loop_budget`).

The error field and ``backward-swap`` evaluate f once a pixel, over neighbouring pixels: they
rely on :func:`bins_serve`. Without a cap (GPU drivers) nothing here applies.
"""

from __future__ import annotations

import math

from ..gl.context import GLContext
from .bins import HandleBins

__all__ = [
    "CAPPED_NEWTON_HANDLES",
    "FORWARD_EVALUATIONS",
    "LOOP_MARGIN",
    "NEWTON_EVALUATIONS",
    "NEWTON_PASSES",
    "bins_serve",
    "check_loop_budget",
    "check_plain_loops",
    "check_plain_loops3",
    "newton_visits_all",
    "plain_handles_most",
    "plain_loops",
    "plain_loops3",
    "walks_checked",
]

#: The most evaluations of f an invocation of a pass that is not Newton's makes (the points
#: pass evaluates two points an invocation) ...
FORWARD_EVALUATIONS = 2
#: ... and the loop iterations left to the loops around them.
LOOP_MARGIN = 1024
#: The evaluations of f one Newton step makes: f, its two differences, f at the next point.
NEWTON_STEP_EVALUATIONS = 4
#: The lanes a CPU renderer runs together (llvmpipe: eight float32 lanes of 256-bit vectors),
#: whose loop iterations it counts together: lanes walking different bins add up.
LANES = 8
#: The evaluations of f an invocation of a Newton pass makes at most, its first dispatch at
#: a list of points: f and its two differences for each of 16 steps, f once more, nine for
#: the stretch at the last point and the identity's check (``warp/newton.glsl``).
NEWTON_EVALUATIONS = 1 + 3 * 16 + 9 + 1


#: The passes that run Newton's method: each invocation evaluates f (and a Jacobian) up to
#: tens of times, walking every handle two or three times per evaluation.
NEWTON_PASSES = frozenset(
    {
        "warp/inverse.comp.glsl",
        "warp/inverse_points.comp.glsl",
        "mls3/inverse.comp.glsl",
        "volume/newton.comp.glsl",
        "volume/folds.comp.glsl",
    }
)
#: The most handles those passes take where the driver caps an invocation's loop iterations
#: (:attr:`glmls.gl.GLContext.loop_limit`): they make only the evaluations of f that fit
#: within Mesa's 65,535 (``warp_evaluations``, ``mls3_evaluations``), and at sixteen handles
#: a loop iteration (mls/handles.glsl) beyond this count too few would fit for Newton's steps.
CAPPED_NEWTON_HANDLES = 8192


def check_loop_budget(
    gl: GLContext, entry: str, count: int, *, binned: bool = False, evaluation: int = 0
) -> None:
    """``ValueError`` where pass ``entry`` with ``count`` handles, visited all, could run
    more loop iterations than ``gl``'s driver runs in one invocation: it would leave handles
    out of f without a word. Through bins (``binned``) the walks' lengths vary with the
    point: the Newton passes then keep only the evaluations the cap left whole
    (``common/loops.glsl``), and are refused where one Newton step (four evaluations of f,
    ``evaluation`` loop iterations each: :meth:`~glmls.engine.bins.HandleBins.
    evaluation_loops`) cannot fit: no point would get past its first."""
    if gl.loop_limit is None or entry not in NEWTON_PASSES:
        return
    if binned:
        if not _fits(gl.loop_limit, NEWTON_STEP_EVALUATIONS * evaluation):
            raise ValueError(
                f"{count:,} handles crowd the spatial bins: one step of Newton's method (the "
                f"inverse of f: {NEWTON_STEP_EVALUATIONS} evaluations of f) may take "
                f"{NEWTON_STEP_EVALUATIONS * evaluation:,} loop iterations through them, more "
                f"than Mesa's llvmpipe runs in one shader invocation ({gl.loop_limit:,}); use "
                f"bins=False (at most {CAPPED_NEWTON_HANDLES:,} handles), fewer handles or a "
                f"GPU"
            )
        return
    if count > CAPPED_NEWTON_HANDLES:
        raise ValueError(
            f"{count:,} handles: the inverse of f (Newton's method) takes at most "
            f"{CAPPED_NEWTON_HANDLES:,} on Mesa's llvmpipe, which stops a shader's loops after "
            f"{gl.loop_limit:,} iterations (more would leave handles out); use fewer handles "
            f"or a GPU"
        )


def plain_loops(count: int, segments: int, *, full: bool) -> int:
    """The most loop iterations of an invocation's evaluations of f that visit every one of
    ``count`` point handles (sixteen a loop iteration: ``MLS_BLOCKS`` of
    ``glmls/shaders/mls/handles.glsl``) and ``segments`` segment handles (one an iteration):
    the nearest and the moments for both points of a pair, the nearest beyond the snapping
    distance for each, and (``full``, affine) the float64 moments for each, four handles an
    iteration; the segments for each point in each of those. The lanes of a vector walk
    the same loops: the count is theirs together."""
    blocks = math.ceil(count / 16) + 1
    loops = 4 * blocks + (4 + 2 * full) * segments + 16
    if full:
        loops += FORWARD_EVALUATIONS * (math.ceil(count / 4) + 1)
    return loops


def plain_handles_most(limit: int | None, *, full: bool = False) -> int | None:
    """The most point handles that evaluations of f visiting every one take on a driver that
    caps an invocation's loops at ``limit`` (:func:`plain_loops`; None: no cap, no such
    count)."""
    if limit is None:
        return None
    low, high = 0, 16 * limit  # plain_loops grows with the count: the last that fits
    while low < high:
        middle = (low + high + 1) // 2
        low, high = (
            (middle, high) if _fits(limit, plain_loops(middle, 0, full=full)) else (low, middle - 1)
        )
    return low


def _fits(limit: int, loops: int) -> bool:
    return loops + LOOP_MARGIN <= limit


def bins_serve(
    limit: int | None,
    bins: HandleBins,
    *,
    gaussian: bool,
    full: bool,
    requested: str | None,
) -> bool:
    """Whether ``bins`` may serve f on a driver that caps an invocation's loops at ``limit``
    (None: no cap, they always may). Two evaluations through them must fit (a pass makes
    two an invocation), else an automatic binning gives way to visiting every handle and a
    ``requested`` one (what asked for it, for the message: ``"bins=True"``, or bins that
    a compiled pass needs for another image's radius) is refused with ``ValueError``."""
    if limit is None:
        return True
    loops = bins.evaluation_loops(gaussian=gaussian, full=full)
    if not _fits(limit, FORWARD_EVALUATIONS * loops):
        if requested:
            everything = _fits(limit, plain_loops(bins.handles, 0, full=full))
            raise ValueError(
                f"{requested}: one evaluation of f through the spatial bins may take "
                f"{loops:,} loop iterations where thousands of handles crowd a few bins, and "
                f"a pass makes {FORWARD_EVALUATIONS} an invocation: more than Mesa's "
                f"llvmpipe runs in one shader invocation ({limit:,}; it would leave handles "
                f"out); use {'bins=False' if everything else 'fewer handles'} or a GPU"
            )
        return False
    return True


def walks_checked(limit: int | None, bins: HandleBins, *, gaussian: bool, full: bool) -> bool:
    """Whether the passes that evaluate f on a lattice through ``bins`` check that a
    driver's cap on an invocation's loops (``limit``; None: no cap) left each evaluation
    whole: where :data:`LANES` lanes each walking their most apart could exceed it (the
    estimate of :func:`bins_serve` is one lane's, and for the gaussian a point's in the
    handles' midst). The passes at a list of points, read back anyway, always check."""
    if limit is None:
        return False
    bound = bins.evaluation_loops(gaussian=gaussian, full=full, bound=True)
    return not _fits(limit, LANES * FORWARD_EVALUATIONS * bound)


def newton_visits_all(
    limit: int | None, entry: str, bins: HandleBins, *, count: int, gaussian: bool, full: bool
) -> bool:
    """Whether pass ``entry``, a Newton pass on a driver that caps an invocation's loops at
    ``limit``, visits every handle rather than walk ``bins``: where
    :data:`NEWTON_EVALUATIONS` evaluations through the bins would not fit (thousands of
    handles crowd a few bins, or a gaussian's reach holds hundreds), visiting every handle
    costs fewer loop iterations an evaluation, and the pass takes that many handles (at
    most :data:`CAPPED_NEWTON_HANDLES`): it then makes more evaluations within the cap.
    The handles stay sorted by bin: visiting them all, their order does not matter."""
    if limit is None or entry not in NEWTON_PASSES or count > CAPPED_NEWTON_HANDLES:
        return False
    near = bins.evaluation_loops(gaussian=gaussian, full=full)
    plain = plain_loops(count, 0, full=full) // FORWARD_EVALUATIONS
    return not _fits(limit, NEWTON_EVALUATIONS * near) and plain < near


def plain_loops3(count: int) -> int:
    """The loop iterations of one evaluation of the 3D f over ``count`` handles where its
    solve is plain (``mls3_evaluation_iterations`` of ``glmls/shaders/mls3/newton.glsl``):
    the nearest, a snapped point's nearest beyond the snapping distance and the moments,
    sixteen handles an iteration, and the polar factor's steps. A point whose weighted
    handles are degenerate also sums them in float64, four an iteration."""
    return 3 * (math.ceil(count / 16) + 1) + 10 + 2


def check_plain_loops3(limit: int | None, count: int) -> None:
    """``ValueError`` where one evaluation of the 3D f over ``count`` handles takes more loop
    iterations than a driver capped at ``limit`` runs in one invocation (None: no cap), even
    where its solve is plain (:func:`plain_loops3`). The passes at a list of points report
    the evaluations that the cap cut short otherwise (the float64 solve, the Jacobian's
    passes and differences; ``mls3/points.comp.glsl``, :mod:`glmls.engine.passes3`)."""
    if limit is None or _fits(limit, plain_loops3(count)):
        return
    raise ValueError(
        f"{count:,} 3D handles: one evaluation of f visiting them all takes more loop "
        f"iterations than Mesa's llvmpipe runs in one shader invocation ({limit:,}; it "
        f"would leave handles out); use fewer handles or a GPU"
    )


def check_plain_loops(
    limit: int | None,
    count: int,
    segments: int,
    *,
    full: bool,
    binned: bool = False,
    radius: bool = False,
) -> None:
    """``ValueError`` where evaluations of f that visit every one of ``count`` handles and
    ``segments`` segments take more loop iterations than a driver capped at ``limit`` runs
    in one invocation (None: no cap); ``binned``: spatial bins were tried first and could
    not serve; ``radius``: the weight has a radius (bins could serve where asked)."""
    if limit is None or _fits(limit, plain_loops(count, segments, full=full)):
        return
    what = f"{count:,} handle{'s' * (count != 1)}"
    what += f" and {segments:,} segment{'s' * (segments != 1)}" if segments else ""
    if binned:
        advice = "nor can the spatial bins, which thousands crowd; use fewer handles or a GPU"
    elif radius:
        advice = "use fewer handles, spatial bins (bins=None) where they spread, or a GPU"
    else:
        advice = "use fewer handles, a weight with a radius (spatial bins), or a GPU"
    raise ValueError(
        f"{what}: one evaluation of f visiting them all takes more loop iterations than "
        f"Mesa's llvmpipe runs in one shader invocation ({limit:,}; it would leave handles "
        f"out); {advice}"
    )
