"""glmls in processes forked from one that used GL (data-loader workers): glmls.warp works
there through a helper process, bit for bit as in the parent; making a context there raises
GLUnavailableError at once; children forked before any GL and spawned children make their own
contexts; the parent keeps working. Each case runs as a script in a fresh interpreter, every
child with a timeout, so that a hang fails the test instead of stopping the suite."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from glmls.gl import helper

COMMON = """
import multiprocessing, os, sys, threading
import numpy as np
import glmls
SRC = np.array([[10.0, 10.0], [50.0, 12.0], [30.0, 40.0], [12.0, 44.0]])
DST = np.array([[14.0, 8.0], [50.0, 12.0], [33.0, 36.0], [12.0, 44.0]])
METHODS = ("quads", "backward")

def image(seed):
    return np.random.default_rng(seed).integers(0, 255, (48, 56, 3), dtype=np.uint8)

def warp(seed, method="quads"):
    return glmls.warp(image(seed), SRC, DST, weight="gaussian", radius=30.0, method=method)

def warps(seed):
    return [warp(seed, method) for method in METHODS], os.getpid()

def in_child(function, timeout=60):
    # function() in a forked child, bounded by timeout: its result, or the exception it raised
    receive, send = multiprocessing.Pipe(duplex=False)
    def main():
        try:
            send.send((True, function()))
        except BaseException as error:
            send.send((False, error))
    child = multiprocessing.get_context("fork").Process(target=main)
    child.start()
    child.join(timeout)
    if child.is_alive():
        child.kill()
        raise AssertionError("the forked child hung")
    assert receive.poll(), f"the child exited with {child.exitcode} and no answer"
    ok, value = receive.recv()
    if not ok:
        raise value
    return value

def check_parent(expected):
    for method, result in zip(METHODS, expected):
        assert np.array_equal(warp(0, method), result), method
    assert glmls.gl.get_context().mgl.error == "GL_NO_ERROR"
"""


def run_script(body: str, tmp_path, timeout: float = 120) -> str:
    """``body`` after COMMON, as a script file (spawned workers import its functions)."""
    script = tmp_path / "script.py"
    script.write_text(COMMON + "\n" + textwrap.dedent(body))
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=timeout
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done.stdout


def test_a_child_forked_after_the_parent_warped_warps_bit_for_bit(tmp_path):
    out = run_script(
        """
        expected = warps(0)[0]
        results, pid = in_child(lambda: warps(0))
        assert pid != os.getpid()
        for method, a, b in zip(METHODS, results, expected):
            assert a.dtype == b.dtype and np.array_equal(a, b), method

        def errors():  # what fails in the child fails as in the parent
            found = []
            for attempt in (
                lambda: glmls.warp(image(0), SRC, DST, methd="quads"),
                lambda: glmls.warp(image(0), SRC, DST, weight="nope"),
                lambda: glmls.gl.get_context(),  # a context of its own: refused, with advice
            ):
                try:
                    attempt()
                    found.append("no error")
                except Exception as error:
                    found.append(f"{type(error).__name__}: {error}")
            return found
        print("\\n".join(in_child(errors)))
        check_parent(expected)
        """,
        tmp_path,
    )
    unknown, bad_value, context = out.splitlines()
    assert unknown == "TypeError: warp() got an unknown keyword methd"
    assert bad_value.startswith("ValueError") and "nope" in bad_value
    assert context.startswith("GLUnavailableError") and "'spawn' start method" in context
    assert "glmls.MLS objects made without a ctx" in context and "render_*" in context


MLS_USES = """
POINTS = np.array([[3.5, 7.0], [20.0, 30.0], [44.0, 5.5]])

def uses(m):
    # every GPU method of a 2D MLS, as a dict of results
    xy, residual = m.coordinate_map((48, 56), residual=True)
    s, valid = m.inverse(POINTS, return_valid=True)
    out = {
        "f": m(POINTS), "M": m.matrices(POINTS)[0], "T": m.matrices(POINTS)[1],
        "inverse": s, "valid": valid, "grid4": glmls.InverseMLS(m, grid=4)(POINTS),
        "residuals": m.residuals(POINTS, POINTS + 1), "warp": m.warp(image(0)),
        "backward": m.warp(image(0), method="backward", interpolation="linear"),
        "map": xy, "map_residual": residual, "error": m.error_field((48, 56), grid=4),
        "bounds": np.array(m.bounds((48, 56)).origin), "mesh": m.mesh((48, 56), grid=8)[1],
    }
    m.set_handles(SRC, DST + 1.5)
    out["moved"] = m(POINTS)
    m.set_handles(SRC, DST)
    return out

def uses3(m):
    volume = np.random.default_rng(3).integers(0, 255, (10, 12, 14), dtype=np.uint8)
    points = np.array([[1.0, 2.0, 3.0], [7.5, 4.0, 2.0]])
    faces = np.array([[0, 1, 2]])
    deformed = m.deform((np.array([[0.0, 0, 0], [5, 0, 0], [0, 5, 1]]), faces))
    return {
        "f": m(points), "J": m.jacobian(points)[1], "inverse": m.inverse(points),
        "warp": m.warp(volume), "backward": m.warp(volume, method="backward"),
        "normals": deformed.normals, "det": deformed.det_j,
        "bounds": np.array(m.bounds((10, 12, 14)).origin),
    }

def same(a, b):
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key], equal_nan=True), key
"""


def test_an_mls_works_in_a_child_forked_after_the_parent_used_gl(tmp_path):
    """An MLS made in the child, and one the parent made before the fork, do all their GPU
    work there (through the helper) with the parent's results bit for bit; its errors are
    the parent's; release and the GL internals say what they are."""
    out = run_script(
        MLS_USES
        + textwrap.dedent(
            """
        SRC3 = np.array([[1.0, 1, 1], [12, 2, 1], [2, 10, 3], [3, 4, 8], [10, 9, 7]])
        DST3 = SRC3 + [[0.5, 0, 0], [0, 1, 0], [0, 0, -1], [1, 1, 0], [0, 0, 0]]
        parents = glmls.MLS(SRC, DST, weight="gaussian", radius=30.0)
        expected = uses(parents)
        parents3 = glmls.MLS(SRC3, DST3, transform="similarity")
        expected3 = uses3(parents3)
        # handles in units of voxels of (2, 1, 0.5), a radius weight's default radius the
        # diagonal in those units: the helper's MLS must take the spacing too
        SPACED = dict(weight="gaussian", shape=(10, 12, 14), spacing=(2.0, 1.0, 0.5))
        spaced = glmls.MLS(SRC3, DST3, **SPACED)
        expected_spaced = uses3(spaced)
        assert not np.array_equal(
            expected_spaced["f"], uses3(glmls.MLS(SRC3, DST3, **(SPACED | {"spacing": None})))["f"]
        )

        def in_the_child():
            made = glmls.MLS(SRC, DST, weight="gaussian", radius=30.0)
            same(uses(made), expected)
            same(uses(parents), expected)  # made before the fork
            same(uses3(glmls.MLS(SRC3, DST3, transform="similarity")), expected3)
            same(uses3(parents3), expected3)
            made_spaced = glmls.MLS(SRC3, DST3, **SPACED)
            assert made_spaced.spacing == (2.0, 1.0, 0.5) and "spacing=(2.0" in repr(made_spaced)
            same(uses3(made_spaced), expected_spaced)
            same(uses3(spaced), expected_spaced)  # made before the fork
            found = []
            for attempt in (
                lambda: glmls.MLS(SRC, DST, weight="gaussian")(POINTS),  # no radius
                lambda: glmls.MLS(SRC, DST, transform="affine").set_handles(SRC[:2], DST[:2]),
                lambda: made.kernel,
                lambda: made.ctx,
            ):
                try:
                    attempt()
                    found.append("no error")
                except Exception as error:
                    found.append(type(error).__name__)
            made.release()
            with glmls.MLS(SRC3, DST3) as m3:
                pass
            for released in (made, m3):
                try:
                    released(POINTS if released is made else SRC3)
                    found.append("no error")
                except Exception as error:
                    found.append(type(error).__name__)
            found.append(repr(made))
            return found

        found = in_child(in_the_child, timeout=240)
        print("\\n".join(found))
        same(uses(parents), expected)  # the parent's objects still work
        assert glmls.gl.get_context().mgl.error == "GL_NO_ERROR"
        """
        ),
        tmp_path,
        timeout=300,
    )
    radius, degenerate, kernel, ctx, released, released3, shown = out.splitlines()
    assert radius == "ValueError" and degenerate == "DegenerateHandlesError"
    assert kernel == ctx == "GLUnavailableError"
    assert released == released3 == "ReleasedError"
    assert shown.startswith("MLS(4 handles") and shown.endswith(", released)")


def test_children_forked_before_any_gl_and_spawned_children_work(tmp_path):
    run_script(
        """
        if __name__ == "__main__":
            before, pid = in_child(lambda: warps(1))
            expected = warps(1)[0]  # now the parent uses GL
            for a, b in zip(before, expected):
                assert np.array_equal(a, b)
            with multiprocessing.get_context("spawn").Pool(1) as pool:
                spawned, pid = pool.apply(warps, (1,))
            for a, b in zip(spawned, expected):
                assert np.array_equal(a, b)
            check_parent(warps(0)[0])
        """,
        tmp_path,
    )


def test_a_child_forked_while_another_thread_holds_the_context_works(tmp_path):
    run_script(
        """
        expected = warps(2)[0]
        context = glmls.gl.get_context()
        held, release = threading.Event(), threading.Event()

        def hold():
            with context.use():
                held.set()
                release.wait(60)

        thread = threading.Thread(target=hold)
        thread.start()
        held.wait(60)
        try:
            results, pid = in_child(lambda: warps(2))
        finally:
            release.set()
            thread.join()
        for a, b in zip(results, expected):
            assert np.array_equal(a, b)
        check_parent(warps(0)[0])
        """,
        tmp_path,
    )


def test_a_fork_pool_of_persistent_workers_warps_after_the_parent_did(tmp_path):
    """A multiprocessing Pool standing in for a DataLoader: two forked workers, each doing
    several warps through its one helper process, while the parent warps too."""
    run_script(
        """
        expected = [warps(seed)[0] for seed in range(6)]
        with multiprocessing.get_context("fork").Pool(2) as pool:
            pending = pool.map_async(warps, range(6), chunksize=1)
            check_parent(expected[0])  # the parent works meanwhile
            answers = pending.get(timeout=90)
            again = pool.map(warps, range(6), chunksize=3)  # the same workers again
        pids = {pid for _, pid in answers + again}
        assert len(pids) <= 2 and os.getpid() not in pids, pids
        for (results, _), wanted in zip(answers + again, expected + expected):
            for a, b in zip(results, wanted):
                assert np.array_equal(a, b)
        check_parent(expected[0])
        """,
        tmp_path,
    )


def test_the_helper_raises_and_warns_in_the_caller():
    with pytest.warns(UserWarning, match="from the helper"):
        assert helper.call("warnings", "warn", ("from the helper", UserWarning)) is None
    with pytest.raises(ZeroDivisionError):
        helper.call("operator", "truediv", (1, 0))
    assert helper.call("operator", "add", (np.arange(3), 1)).tolist() == [1, 2, 3]


def test_pictures_and_reports_render_in_a_child_forked_after_the_parent_used_gl(tmp_path):
    """The analysis pictures (drawn on the GPU) and the reports that hold them: in the child
    through the helper, equal to the parent's; a Canvas of one's own is refused there."""
    out = run_script(
        """
        import hashlib

        from glmls import analysis as A

        m = glmls.MLS(SRC, DST, weight="gaussian", radius=30.0)
        POINTS = np.array([[12.0, 12.0], [48.0, 14.0], [30.0, 38.0], [14.0, 42.0], [30.0, 20.0]])

        def pictures(m):  # digests: a pipe holds 64 KiB until the parent reads it
            picture = image(0)
            errors = A.triangle_errors(m, POINTS)
            built = A.construction_errors(picture, m.warp(picture), m, POINTS)
            report = A.report(picture, m, POINTS, construction=False, mesh_grid=8)
            drawn = {
                "field": A.render_field(A.error_field(m, (48, 56), grid=4)),
                "handles": A.render_handles(picture, SRC, DST),
                "triangulation": A.render_triangulation(picture, POINTS, errors.simplices),
                "triangles": A.render_triangle_errors(picture, errors),
                "mesh": A.render_mesh(picture, m.mesh((48, 56), grid=8)[1]),
                "construction": A.render_construction_errors(picture, built),
                **{"report " + name: p for name, p in report.images.items()},
            }
            digests = {k: (p.shape, hashlib.sha256(p.tobytes()).hexdigest())
                       for k, p in drawn.items()}
            return digests, report.summary["gl_renderer"]

        expected, renderer = pictures(m)

        def child():
            made = glmls.MLS(SRC, DST, weight="gaussian", radius=30.0)
            try:
                A.Canvas((8, 8))
                refused = "no error"
            except glmls.GLUnavailableError as error:
                refused = "GLUnavailableError"
            return pictures(m), pictures(made), refused

        (before, renderer_before), (made, renderer_made), refused = in_child(child)
        assert before == made == expected
        assert renderer_before == renderer_made == renderer and renderer
        print(refused, len(expected))
        """,
        tmp_path,
        timeout=180,
    )
    refused, count = out.split()
    assert refused == "GLUnavailableError" and int(count) > 6


def test_the_parents_contexts_are_refused_in_the_child_at_once(tmp_path):
    """A GL context made before the fork, handed to glmls in the child (``ctx=``, its
    programs, an MLS's GL internals), raises GLUnavailableError at once, before any GL call:
    GL there would hang or draw on the parent's driver state."""
    out = run_script(
        """
        from glmls.gl.context import create_headless

        own, default = create_headless(), glmls.gl.get_context()
        m = glmls.MLS(SRC, DST, ctx=own)
        expected = m(SRC)

        def child():
            found = []
            for attempt in (
                lambda: glmls.MLS(SRC, DST, ctx=own),
                lambda: glmls.MLS(SRC, DST, ctx=default),
                lambda: glmls.warp(image(0), SRC, DST, ctx=own),
                lambda: glmls.warp_batch(image(0)[None], SRC[None], DST[None], ctx=own),
                lambda: glmls.analysis.render_field(np.zeros((4, 4)), ctx=own),
                lambda: glmls.gl.WarpPipeline.of(own),
                lambda: own.compute("mls/points.comp.glsl", {"MLS_STORAGE": 0}),
                lambda: m.ctx,
                lambda: m.kernel,
            ):
                try:
                    attempt()
                    found.append("no error")
                except Exception as error:
                    found.append(type(error).__name__)
            return found, np.array_equal(m(SRC), expected)  # through the helper

        found, same = in_child(child)
        print(" ".join(found), same)
        """,
        tmp_path,
    )
    *found, same = out.split()
    assert found == ["GLUnavailableError"] * 9 and same == "True"


def test_a_context_held_by_another_thread_at_the_fork_releases_in_the_child(tmp_path):
    """A context's lock held by another thread of the parent at the fork (a warp running
    there) is never released in the child: releasing or unbinding the context there must not
    wait for it."""
    out = run_script(
        """
        from glmls.gl.context import create_headless

        own, default = create_headless(), glmls.gl.get_context()
        m = glmls.MLS(SRC, DST, ctx=own)
        held, done = threading.Event(), threading.Event()

        def hold():
            with own.use(), default.use():
                held.set()
                done.wait(60)

        thread = threading.Thread(target=hold)
        thread.start()
        held.wait(60)

        def child():
            own.unbind()
            m.release()
            own.release()
            default.release()
            glmls.gl.context.release_all()
            return own.released, default.released, m.released

        try:
            print(in_child(child, timeout=20))
        finally:
            done.set()
            thread.join()
        assert not own.released and np.array_equal(m(SRC), m(SRC))  # the parent's still work
        """,
        tmp_path,
    )
    assert out.strip() == "(True, True, True)"


def test_image_reads_of_another_thread_at_the_fork_do_not_block_the_childs(tmp_path):
    """A thread of the parent inside glmls.imread at the fork (the locks around Pillow's limit
    and tifffile's logger held): the child's reads must not wait for it for ever."""
    out = run_script(
        """
        import logging
        import shutil
        import tempfile

        from glmls.files import images, tiffs

        folder = tempfile.mkdtemp()
        for suffix in ("png", "tif"):
            glmls.imwrite(f"{folder}/picture.{suffix}", image(0))

        def holding(lock, function):
            held, done = threading.Event(), threading.Event()

            def hold():
                with lock:
                    held.set()
                    done.wait(60)

            thread = threading.Thread(target=hold)
            thread.start()
            held.wait(60)
            try:
                return in_child(function, timeout=20)
            finally:
                done.set()
                thread.join()

        pillow = holding(images._pillow_lock, lambda: glmls.imread(f"{folder}/picture.png").shape)
        tiff = holding(tiffs._lock, lambda: glmls.imread(f"{folder}/picture.tif").shape)
        with tiffs.quiet_tifffile():  # a read under way at the fork: the child's logger level
            level = in_child(lambda: logging.getLogger("tifffile").level)
        print(pillow, tiff, level == logging.getLogger("tifffile").level)
        shutil.rmtree(folder)
        """,
        tmp_path,
    )
    assert out.strip() == "(48, 56, 3) (48, 56, 3) True"


def test_forkserver_workers_of_a_script_that_uses_gl_at_import(tmp_path):
    """forkserver (Python 3.14's default on Linux) forks its workers from a server process
    started fresh; a script that makes an MLS at its top level (imported again by each
    worker, and by the server where told to preload it) gives the parent's results there."""
    run_script(
        """
        BEND = glmls.MLS(SRC, DST, transform="similarity")  # GL at import, in the server too

        def both(seed):
            return warps(seed)[0], BEND.warp(image(seed), method="backward"), os.getpid()

        if __name__ == "__main__":
            expected = warps(3)[0], BEND.warp(image(3), method="backward")
            for preload in (False, True):
                context = multiprocessing.get_context("forkserver")
                if preload:
                    context.set_forkserver_preload(["__main__"])
                with context.Pool(1) as pool:
                    quads, bent, pid = pool.apply(both, (3,))
                assert pid != os.getpid()
                assert all(np.array_equal(a, b) for a, b in zip(quads, expected[0]))
                assert np.array_equal(bent, expected[1])
        """,
        tmp_path,
        timeout=180,
    )


def test_far_target_analyses_in_a_child_forked_after_the_parent_used_gl(tmp_path):
    """The analyses of an MLS whose targets lie far from its sources judge flatness by f
    less the targets' translation, which the helper process's kernel takes off: a forked
    child finds the parent's folds, flipped triangles and error field (equal, the error
    field within 1e-5 of its largest value)."""
    run_script(
        """
        from glmls.analysis import error_field, foldovers, triangle_errors
        rng = np.random.default_rng(0)
        src = rng.uniform(4, 60, (12, 2))
        dst = src + rng.normal(0, 4, src.shape)
        dst[0], dst[1] = src[1], src[0]
        far = dst + [1e5, -7e4]
        ref = np.array([[8.0, 8.0], [56.0, 10.0], [30.0, 54.0], [20.0, 30.0], [44.0, 40.0]])

        def analyses():
            with glmls.MLS(src, far) as m:
                folds = foldovers(m, (64, 64), grid=1).mask
                field = error_field(m, (64, 64))
                flipped = triangle_errors(m, ref).flipped
            return folds, field, flipped

        expected = analyses()
        assert 0 < expected[0].sum() < expected[0].size
        found = in_child(analyses, timeout=240)
        assert np.array_equal(found[0], expected[0]), (found[0].sum(), expected[0].sum())
        scale = np.abs(expected[1]).max()
        assert np.abs(found[1] - expected[1]).max() <= 1e-5 * scale
        assert np.array_equal(found[2], expected[2])
        """,
        tmp_path,
        timeout=300,
    )


def test_3d_analyses_in_a_child_forked_after_the_parent_used_gl(tmp_path):
    """The 3D analyses of a GPU MLS (cell Jacobians, tetrahedra, the error field) run in a
    forked child through the helper process: near and far targets, and a radius weight
    without a radius (whose analyses take the volume's diagonal), give the parent's
    results (the fold maps and inverted flags equal; det J, distance errors and the error
    field within 1e-4 of their largest value: the child's MLS for the volume may scale
    the handles otherwise)."""
    run_script(
        """
        from glmls.analysis import cell_jacobians, tetrahedron_errors
        rng = np.random.default_rng(1)
        p = rng.uniform(1, 14, (10, 3))
        q = p + rng.normal(0, 1.5, p.shape)
        q[0], q[1] = p[1], p[0]  # some cells fold
        r = rng.uniform(0, 15, (24, 3))
        gaussian = {"weight": "gaussian", "shape": (9, 10, 11)}
        cases = [(q, {}), (q + [1e5, -7e4, 3e4], {}), (q, gaussian)]

        def analyses():
            found = []
            for targets, options in cases:
                with glmls.MLS(p, targets, **options) as m:
                    cells = cell_jacobians(m, (12, 14, 16))
                    tetra = tetrahedron_errors(m, r)
                    field = glmls.analysis.volume_error_field(m, (12, 14, 16))
                found.append((cells.folded, cells.det, tetra.inverted, tetra.distance, field))
            return found

        expected = analyses()
        assert any(0 < e[0].sum() < e[0].size for e in expected)

        def compared():  # in the child, which has the parent's results (a pipe holds little)
            misses = []
            for found, wanted in zip(analyses(), expected):
                misses.append(not np.array_equal(found[0], wanted[0]))
                misses.append(not np.array_equal(found[2], wanted[2]))
                for k in (1, 3, 4):
                    scale = max(np.abs(wanted[k]).max(), 1e-12)
                    misses.append(float(np.abs(found[k] - wanted[k]).max() / scale))
            return misses

        misses = in_child(compared, timeout=240)
        assert not any(misses[0::5]) and not any(misses[1::5]), misses
        assert max(m for i, m in enumerate(misses) if i % 5 > 1) <= 1e-4, misses
        """,
        tmp_path,
        timeout=300,
    )
