"""The window's interaction logic, without a window: picking, editing, undo, key bindings."""

from __future__ import annotations

import numpy as np
import pytest

from glmls.app.controller import (
    BINDINGS,
    COMMANDS,
    CONSTRUCTIONS,
    Controller,
    Key,
    Move,
    Press,
    Release,
    Settings,
    pick,
)
from glmls.app.volume_controller import VolumeController, VolumeSettings
from glmls.core.config import WEIGHTS, MLSConfig, image_diagonal
from glmls.imaging.source import BORDERS

SRC = np.array([[10.0, 10.0], [50.0, 10.0], [30.0, 40.0]])


def make(**options) -> Controller:
    return Controller(SRC, SRC + [2.0, 0.0], (60, 80), pick_radius=5.0, **options)


def drag(c: Controller, a, b, **press) -> None:
    c.feed(Press(*a, **press))
    c.feed(Move(*b))
    c.feed(Release(*b))


def test_pick_within_radius_only():
    points = np.array([[0.0, 0.0], [10.0, 0.0]])
    assert pick(points, 1.0, 1.0, 2.0) == 0
    assert pick(points, 8.5, 0.0, 2.0) == 1
    assert pick(points, 5.0, 0.0, 2.0) is None  # between, out of reach
    assert pick(points, 5.0, 0.0, 5.0) == 1  # a tie goes to the later (drawn on top)
    assert pick(np.zeros((0, 2)), 0, 0, 10) is None


def test_drag_moves_the_target_only():
    c = make()
    drag(c, (12, 10), (20, 25))
    np.testing.assert_array_equal(c.dst[0], [20, 25])
    np.testing.assert_array_equal(c.src, SRC)
    assert len(c.src) == 3 and not c.dragging


def test_shift_drag_moves_the_source():
    c = make()
    drag(c, (50, 10), (55, 20), mods=frozenset({"shift"}))
    np.testing.assert_array_equal(c.src[1], [55, 20])
    np.testing.assert_array_equal(c.dst[1], [52, 10])


def test_click_on_empty_space_adds_a_handle_with_p_equal_q():
    c = make()
    revision = c.revision
    c.feed(Press(70, 50))
    c.feed(Release(70, 50))
    assert len(c.src) == 4
    np.testing.assert_array_equal(c.src[3], [70, 50])
    np.testing.assert_array_equal(c.dst[3], [70, 50])
    assert c.revision > revision


def test_press_on_empty_space_and_drag_pulls_the_new_handle():
    c = make()
    drag(c, (70, 50), (75, 45))
    np.testing.assert_array_equal(c.src[3], [70, 50])
    np.testing.assert_array_equal(c.dst[3], [75, 45])


def test_right_click_deletes_by_target_or_source():
    c = make()
    c.feed(Press(32, 40, "right"))  # q of handle 2
    assert len(c.src) == 2
    c.feed(Press(10, 10, "right"))  # p of handle 0 (q is 2 px away too)
    assert len(c.src) == 1
    c.feed(Press(0, 59, "right"))  # nothing there
    assert len(c.src) == 1


def test_drags_stay_on_the_image():
    c = make()
    drag(c, (12, 10), (-100, 500))
    np.testing.assert_array_equal(c.dst[0], [-0.5, 59.5])


@pytest.mark.parametrize("mode", ["points", "segments", "reference"])
def test_a_click_beside_the_image_adds_nothing(mode):
    """A click on the readout panel (how a window is focused) reaches the controller as an
    image point far left of the image: no handle, segment or reference point is added, as
    it was at the border; within the pick radius of the border one still is, clamped."""
    from glmls.app.layout import layout

    c = make(mode=mode)
    lay = layout((800, 300), c.shape, 376)
    x, y = lay.to_image(100.0, 150.0)  # on the panel
    assert x < -c.pick_radius
    before = c.handles
    drag(c, (x, y), (x + 40.0, y))
    drag(c, (40.0, 75.0), (60.0, 75.0))  # below the image, past the radius
    assert c.handles.same_handles(before) and len(c.reference) == 0
    assert c.undo_depth == 0
    drag(c, (-3.0, 20.0), (-3.0, 40.0))  # within 5 px of the border: on it
    added = {"points": c.src[3:], "segments": c.src_segments, "reference": c.reference}
    start = [-0.5, 40.0] if mode == "reference" else [-0.5, 20.0]  # p stays, r is dragged
    assert added[mode].reshape(-1, 2)[0].tolist() == start


def test_reset_while_drawing_a_segment_keeps_it():
    c = make()
    c.feed(Key("d"))
    c.feed(Press(20.0, 50.0))
    c.feed(Move(60.0, 50.0))
    c.feed(Key("r"))  # the drawing ends first, as its own edit
    np.testing.assert_array_equal(c.src_segments, [[[20.0, 50.0], [60.0, 50.0]]])
    np.testing.assert_array_equal(c.dst_segments, c.src_segments)
    np.testing.assert_array_equal(c.dst, SRC)
    c.feed(Key("u"))  # the reset
    np.testing.assert_array_equal(c.dst, SRC + [2.0, 0.0])
    assert len(c.src_segments) == 1


def test_undo_reverts_each_edit_in_turn():
    c = make()
    start = (c.src.copy(), c.dst.copy())
    drag(c, (12, 10), (20, 20))
    c.feed(Press(70, 50))
    c.feed(Release(70, 50))
    c.feed(Press(52, 10, "right"))
    assert len(c.src) == 3 and c.undo_depth == 3
    c.feed(Key("u"))
    assert len(c.src) == 4
    c.feed(Key("Ctrl+Z"))
    assert len(c.src) == 3
    c.feed(Key("Backspace"))
    np.testing.assert_array_equal(c.src, start[0])
    np.testing.assert_array_equal(c.dst, start[1])
    c.feed(Key("u"))
    assert c.message == "nothing to undo"


def test_a_click_that_moves_nothing_leaves_no_undo_step():
    c = make()
    c.feed(Press(12, 10))
    c.feed(Release(12, 10))
    assert c.undo_depth == 0


def test_reset_and_restore():
    c = make()
    c.feed(Key("r"))
    np.testing.assert_array_equal(c.dst, c.src)
    drag(c, (30, 40), (35, 45), mods=frozenset({"shift"}))
    c.feed(Key("R"))
    np.testing.assert_array_equal(c.src, SRC)
    np.testing.assert_array_equal(c.dst, SRC + [2.0, 0.0])
    c.feed(Key("u"))
    np.testing.assert_array_equal(c.src[2], [35, 45])


def test_restore_with_the_handles_as_loaded_leaves_no_undo_step():
    # R pushed a step that changed nothing: the next u seemed to do nothing
    c = make()
    drag(c, (30, 40), (35, 45), mods=frozenset({"shift"}))
    c.feed(Key("u"))
    c.feed(Key("R"))
    assert (c.undo_depth, c.redo_depth) == (0, 1)  # the redo kept, too
    c.feed(Key("U"))
    np.testing.assert_array_equal(c.src[2], [35, 45])
    c.feed(Press(*SRC[0] + [2.0, 0.0]))  # a target grabbed, not moved: R ends the drag
    c.feed(Key("R"))
    c.feed(Key("R"))
    assert not c.dragging and c.undo_depth == 2  # the shift-drag, the first R
    np.testing.assert_array_equal(c.src, SRC)


def test_reference_mode_adds_moves_and_deletes_reference_points():
    c = make()
    c.feed(Key("p"))
    assert c.reference_mode
    c.feed(Press(5, 50))
    c.feed(Release(5, 50))
    drag(c, (5, 50), (8, 52))
    np.testing.assert_array_equal(c.reference, [[8, 52]])
    assert len(c.src) == 3  # handles untouched
    c.feed(Press(8, 52, "right"))
    assert len(c.reference) == 0
    c.feed(Key("u"))
    assert len(c.reference) == 1
    c.feed(Key("p"))
    drag(c, (8, 52), (9, 9))  # back in handle mode: a new handle, not the reference point
    assert len(c.src) == 4


def test_key_bindings_cycle_the_settings():
    c = make()
    seen = set()
    for _ in range(3):
        seen.add(c.settings.config.transform)
        c.feed(Key("t"))
    assert seen == {"rigid", "similarity", "affine"} and c.settings.config.transform == "rigid"
    weights = []
    for _ in WEIGHTS:
        weights.append(c.settings.config.weight)
        c.feed(Key("w"))
    assert weights == list(WEIGHTS)
    constructions = []
    for _ in CONSTRUCTIONS:
        constructions.append((c.settings.method, c.settings.interpolation))
        c.feed(Key("c"))
    assert constructions == list(CONSTRUCTIONS)


def test_border_and_fit_keys():
    c = make()
    borders = []
    for _ in BORDERS:
        borders.append(c.settings.border)
        r = c.revision
        c.feed(Key("b"))
        assert c.revision > r  # the window redraws
    assert borders == list(BORDERS) and c.settings.border == "constant"
    assert not c.settings.fit
    c.feed(Key("o"))
    assert c.settings.fit
    c.feed(Key("o"))
    assert not c.settings.fit


def test_settings_validate_border_and_fit():
    assert Settings(border="wrap", fit=True).border == "wrap"
    with pytest.raises(ValueError, match="unknown border 'mirror'; choose one of constant"):
        Settings(border="mirror")
    with pytest.raises(TypeError, match="fit must be True or False"):
        Settings(fit="yes")  # type: ignore[arg-type]


def test_parameter_keys_change_alpha_or_radius():
    c = make()
    c.feed(Key("+"))
    c.feed(Key("="))
    assert c.settings.config.alpha == 1.5
    for _ in range(20):
        c.feed(Key("-"))
    assert c.settings.config.alpha == 0.25
    c.feed(Key("w"))  # cressman: a radius weight
    assert c.settings.config.radius is None
    c.feed(Key("+"))
    assert c.settings.config.radius == pytest.approx(1.25 * image_diagonal((60, 80)))
    assert c.settings.parameter((60, 80)) == "R 125 px"


def test_grid_keys_step_through_powers_of_two():
    c = make(settings=Settings(grid=4))
    c.feed(Key("g"))
    assert c.settings.grid == 2
    for _ in range(5):
        c.feed(Key("G"))
    assert c.settings.grid == 32


@pytest.mark.parametrize("window", ["image", "volume"])
@pytest.mark.parametrize(
    ("weight", "value", "up", "down"),
    [("idw", 10.0, 10.0, 9.75), ("idw", 0.1, 0.35, 0.1), ("cressman", 1e6, 1e6, 8e5)],
)
def test_plus_never_lowers_and_minus_never_raises_a_start_value_off_the_range(
    window, weight, value, up, down
):
    # --alpha 10 then + gave 4 (the top of the range), --alpha 0.1 then - gave 0.25
    given = {"alpha": value} if weight == "idw" else {"radius": value}
    config = MLSConfig(weight=weight, **given)
    name = "alpha" if weight == "idw" else "radius"
    for key, wanted in (("+", up), ("-", down)):
        if window == "image":
            c = make(settings=Settings(config=config))
        else:
            c = VolumeController(np.zeros((0, 3)), np.zeros((0, 3)), (8, 8, 8))
            c.settings = VolumeSettings(config=config)
        c.feed(Key(key))
        assert getattr(c.settings.config, name) == pytest.approx(wanted)


@pytest.mark.parametrize(
    ("grid", "finer", "coarser"), [(3, 2, 4), (6, 4, 8), (64, 32, 64), (48, 32, 48), (4, 2, 8)]
)
def test_grid_keys_from_a_grid_off_the_steps(grid, finer, coarser):
    # --grid 64 then G (coarser) gave 8, and --grid 3 then G gave 8, past 4
    assert Settings(grid=grid).next_grid(-1).grid == finer
    assert Settings(grid=grid).next_grid(+1).grid == coarser


def test_the_tolerance_key_cycles_the_adaptive_mesh():
    c = make(settings=Settings(grid=4))
    assert c.settings.tolerance is None and c.settings.mesh_options == {"grid": 4}
    seen = []
    for _ in range(3):
        r = c.revision
        c.feed(Key("T"))
        assert c.revision > r
        seen.append(c.settings.tolerance)
    assert seen == [0.25, 0.05, None]
    adaptive = Settings(tolerance=0.05)
    assert adaptive.mesh_options == {"tolerance": 0.05} and adaptive.adaptive == 0.05
    splat = Settings(method="splat", tolerance=0.05)  # the other constructions ignore it
    assert splat.adaptive is None and splat.mesh_options == {"grid": 4}
    with pytest.raises(ValueError, match="tolerance must be a number of pixels, finite and > 0"):
        Settings(tolerance=-1.0)
    with pytest.raises(TypeError, match="tolerance must be a number"):
        Settings(tolerance="0.05")  # type: ignore[arg-type]


def test_overlay_and_help_toggles():
    c = make()
    assert c.overlays == {
        "handles": True,
        "mesh": False,
        "error": False,
        "angle": False,
        "folds": False,
    }
    for key, name in (
        ("h", "handles"),
        ("m", "mesh"),
        ("e", "error"),
        ("a", "angle"),
        ("f", "folds"),
    ):
        before = c.overlays[name]
        c.feed(Key(key))
        assert c.overlays[name] is not before
    c.feed(Key("F1"))
    assert c.help_visible
    c.feed(Key("?"))
    assert not c.help_visible


@pytest.mark.parametrize(
    ("key", "command"),
    [
        ("s", "save_image"),
        ("j", "save_handles"),
        ("S", "save_screenshot"),
        ("l", "load_handles"),
        ("q", "quit"),
        ("Escape", "quit"),
    ],
)
def test_commands_go_to_the_window(key, command):
    c = make()
    revision = c.revision
    assert c.feed(Key(key)) == [command]
    assert c.revision == revision


def test_unknown_keys_do_nothing():
    c = make()
    assert c.feed(Key("Z")) == []
    assert c.feed(Key("F9")) == []


def test_every_binding_is_unique_and_known():
    keys = [key for keys, _, _ in BINDINGS for key in keys]
    assert len(keys) == len(set(keys))
    c = make()
    for keys, action, _ in BINDINGS:
        result = c.feed(Key(keys[0]))
        assert result == ([action] if action in COMMANDS else [])


def test_revision_changes_only_when_handles_or_settings_do():
    c = make()
    r = c.revision
    c.feed(Move(1, 1))  # not dragging
    c.feed(Key("h"))
    assert c.revision == r
    drag(c, (12, 10), (13, 10))
    assert c.revision > r


def test_bad_events_and_inputs():
    c = make()
    with pytest.raises(ValueError, match="unknown mouse button 'back'"):
        c.feed(Press(0, 0, "back"))
    with pytest.raises(TypeError, match="unknown event"):
        c.feed("t")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="same shape"):
        Controller(SRC, SRC[:2], (10, 10))
    with pytest.raises(ValueError, match="src must be finite"):
        Controller([[np.nan, 0]], [[0, 0]], (10, 10))


def test_the_window_falls_back_to_the_grid_where_the_adaptive_mesh_gives_up(gl):
    """Handles pulled so far apart that the adaptive mesh's build exceeds its budget: the
    analysis draws the grid's mesh and error field and says why, and the construction the
    view draws is the grid's until the handles or the tolerance change."""
    from glmls.app.session import Session

    n = 96
    src = np.array([[45.0, 48], [51, 48], [5, 5], [90, 5], [5, 90], [90, 90]])
    dst = src.copy()
    dst[0], dst[1] = [-30.0 * n, 48], [31.0 * n, 48]
    c = Controller(src, dst, (n, n), settings=Settings(tolerance=0.001))
    for name in ("mesh", "error"):
        c.overlays[name] = True
    session = Session(gl, c, (n, n))
    try:
        session.sync()
        analysis = session.analyse(1.0)
        assert "adaptive mesh: tolerance 0.001 px needs more than" in c.message
        assert analysis.field_colours is not None and analysis.geometry
        assert session.construction(c.settings).tolerance is None
        c.feed(Key("T"))  # another tolerance: the adaptive mesh again
        session.sync()
        assert session.construction(c.settings).tolerance == c.settings.tolerance
    finally:
        if session.mls is not None:
            session.mls.release()


def test_loading_3d_handles_into_the_image_window_says_it_takes_2d_ones(tmp_path):
    from glmls.app.commands import load_handles
    from glmls.errors import InputFileError
    from glmls.files.landmarks import write_handles

    points = np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10]])
    write_handles(tmp_path / "h3.json", points, points + 1)
    c = make()
    with pytest.raises(InputFileError, match=r"h3\.json: 3D handles \(x, y, z\), but the window"):
        load_handles(tmp_path / "h3.json", c)
    assert np.array_equal(c.src, SRC)
    write_handles(tmp_path / "h2.json", SRC[:2], SRC[:2] + 1)
    assert len(load_handles(tmp_path / "h2.json", c)) == 2 and np.array_equal(c.src, SRC[:2])


def test_saving_no_handles_is_refused_rather_than_writing_a_file_l_cannot_load(tmp_path):
    # j wrote {"src": [], "dst": []}, which l then refused ("no handles")
    from glmls.app.commands import save_handles

    c = Controller(np.zeros((0, 2)), np.zeros((0, 2)), (100, 120))
    with pytest.raises(ValueError, match="no handles to save"):
        save_handles(tmp_path / "h.json", c)
    assert not (tmp_path / "h.json").exists()


class _Deformed:
    """A session whose f moves every point 20 px right."""

    def deformed_reference(self):
        return self.controller.reference + [20.0, 0.0]


def test_reference_points_are_drawn_where_reference_mode_picks_them():
    # they were drawn at f(r) in reference mode too, while a click picks r: a press on the
    # dot added a new point instead of grabbing it
    from glmls.app.view import shown_reference

    c = make(mode="reference")
    c.feed(Press(30, 30))
    c.feed(Release(30, 30))
    session = _Deformed()
    session.controller = c
    np.testing.assert_array_equal(shown_reference(c, session), [[30, 30]])
    c.feed(Key("p"))  # out of reference mode: none drawn without the angle overlay
    assert shown_reference(c, session) is None
    c.feed(Key("a"))  # the angle overlay: at f(r), the deformed triangles' corners
    np.testing.assert_array_equal(shown_reference(c, session), [[50, 30]])


@pytest.mark.parametrize("key", ["G", "g"])
def test_a_grid_the_construction_refuses_is_said_not_raised(key):
    # paper-quads takes grid 1 only: G raised out of the window, which closed with exit 2
    c = make(settings=Settings(method="paper-quads", grid=1))
    revision = c.revision
    assert c.feed(Key(key)) == []
    assert c.settings.grid == 1 and c.revision == revision
    assert ("grid must be 1" in c.message) == (key == "G")
    c.feed(Key("c"))  # another construction: the grid keys work again
    c.feed(Key("G"))
    assert c.settings.grid == 2
