"""The operating-system window: glfw, a GL 4.3 core context made current in it, and its mouse
and key callbacks turned into the controller's events (positions in image pixels)."""

from __future__ import annotations

import atexit
from collections.abc import Callable

import moderngl

from ..errors import NoDisplayError
from ..gl.llvm import load_llvm_users_first
from .events import KEY_NAMES, Event, Key, Move, Press, Release, Scroll

__all__ = ["NO_DISPLAY_HINT", "GlfwWindow", "NoDisplayError"]

NO_DISPLAY_HINT = (
    "no display for the window ({why}); run it under a display or `xvfb-run -a glmls demo`, "
    "or use the headless commands instead (`glmls --help`; in Python glmls.warp, "
    "glmls.analysis.report)"
)


#: Whether glfw's termination at exit is registered: glfw stays initialised from the first
#: window on, so that closing one window does not close the connection to the display (an
#: X server started by ``xvfb-run`` resets when its last client leaves, and a window opened
#: meanwhile finds no display).
_TERMINATE_AT_EXIT: list[bool] = []
#: glfw's constant of a key name where it is not ``KEY_<NAME>`` of the name in upper case.
_GLFW_NAMES = {"PageUp": "PAGE_UP", "PageDown": "PAGE_DOWN"}


def _text(value: object) -> str:
    return value.decode(errors="replace") if isinstance(value, bytes) else str(value)


class GlfwWindow:
    """A glfw window with a current GL 4.3 core context; :class:`NoDisplayError` if none."""

    def __init__(self, size: tuple[int, int], title: str, *, vsync: bool) -> None:
        try:
            import glfw
        except ImportError as error:  # the glfw shared library is missing
            raise NoDisplayError(NO_DISPLAY_HINT.format(why=f"glfw: {error}")) from None
        self.glfw = glfw
        load_llvm_users_first()  # before the driver's LLVM, as for a headless context
        self._errors: list[str] = []
        glfw.set_error_callback(lambda code, text: self._errors.append(_text(text)))
        if not glfw.init():
            raise NoDisplayError(NO_DISPLAY_HINT.format(why=self._why("glfw could not start")))
        if not _TERMINATE_AT_EXIT:
            atexit.register(glfw.terminate)
            _TERMINATE_AT_EXIT.append(True)
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 4)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        glfw.window_hint(glfw.SCALE_TO_MONITOR, True)
        glfw.window_hint(glfw.SAMPLES, 0)
        self.handle = glfw.create_window(size[0], size[1], title, None, None)
        if not self.handle:
            why = self._why("no OpenGL 4.3 core context")
            raise NoDisplayError(NO_DISPLAY_HINT.format(why=why))
        glfw.make_context_current(self.handle)
        glfw.swap_interval(1 if vsync else 0)

    def _why(self, default: str) -> str:
        return self._errors[-1] if self._errors else default

    def context(self) -> moderngl.Context:
        """The window's GL context for moderngl (the window closes if there is none)."""
        try:
            return moderngl.create_context(require=430)
        except Exception as error:  # glcontext raises bare Exception
            self.close()
            raise NoDisplayError(NO_DISPLAY_HINT.format(why=f"OpenGL: {error}")) from None

    @property
    def framebuffer_size(self) -> tuple[int, int]:
        return tuple(self.glfw.get_framebuffer_size(self.handle))  # type: ignore[return-value]

    @property
    def pixel_ratio(self) -> float:
        """Framebuffer pixels per window unit (2 on a Retina-type screen)."""
        width = self.glfw.get_window_size(self.handle)[0]
        return self.framebuffer_size[0] / width if width else 1.0

    @property
    def content_scale(self) -> float:
        return float(max(self.glfw.get_window_content_scale(self.handle)))

    @property
    def should_close(self) -> bool:
        return bool(self.glfw.window_should_close(self.handle))

    def poll(self, *, wait: float | None = None) -> None:
        """Handle pending events; with ``wait``, first wait up to that many seconds for one."""
        if wait is None:
            self.glfw.poll_events()
        else:
            self.glfw.wait_events_timeout(wait)

    def swap(self) -> None:
        self.glfw.swap_buffers(self.handle)

    def listen(
        self,
        feed: Callable[[Event], None],
        to_image: Callable[[float, float], tuple[float, float]],
        dragging: Callable[[], bool],
    ) -> None:
        """Send mouse and key events to ``feed``: cursor positions (window units) through
        ``to_image``; moves only while ``dragging()``; the wheel as :class:`Scroll`."""
        glfw = self.glfw
        buttons = {
            glfw.MOUSE_BUTTON_LEFT: "left",
            glfw.MOUSE_BUTTON_RIGHT: "right",
            glfw.MOUSE_BUTTON_MIDDLE: "middle",
        }
        special = {  # glfw's key -> its name (events.KEY_NAMES, which a replay takes)
            getattr(glfw, f"KEY_{_GLFW_NAMES.get(name, name.upper())}"): name for name in KEY_NAMES
        }
        modifiers = ((glfw.MOD_SHIFT, "shift"), (glfw.MOD_CONTROL, "ctrl"), (glfw.MOD_ALT, "alt"))

        def cursor(window) -> tuple[float, float]:
            return to_image(*glfw.get_cursor_pos(window))

        def on_button(window, button, action, mods) -> None:
            if button not in buttons:
                return
            x, y = cursor(window)
            if action == glfw.PRESS:
                held = frozenset(name for bit, name in modifiers if mods & bit)
                feed(Press(x, y, buttons[button], held))
            elif action == glfw.RELEASE:
                feed(Release(x, y, buttons[button]))

        def on_move(window, _x, _y) -> None:
            if dragging():
                feed(Move(*cursor(window)))

        def on_scroll(window, _dx, dy) -> None:
            if dy:
                feed(Scroll(*cursor(window), float(dy)))

        def on_char(window, codepoint) -> None:
            feed(Key(chr(codepoint)))

        def on_key(window, key, scancode, action, mods) -> None:
            if action not in (glfw.PRESS, glfw.REPEAT):
                return
            if key in special:
                feed(Key(special[key]))
            elif mods & glfw.MOD_CONTROL and glfw.KEY_A <= key <= glfw.KEY_Z:
                shift = "Shift+" if mods & glfw.MOD_SHIFT else ""
                feed(Key(f"Ctrl+{shift}{chr(key)}"))

        glfw.set_mouse_button_callback(self.handle, on_button)
        glfw.set_cursor_pos_callback(self.handle, on_move)
        glfw.set_scroll_callback(self.handle, on_scroll)
        glfw.set_char_callback(self.handle, on_char)
        glfw.set_key_callback(self.handle, on_key)

    def close(self) -> None:
        """Destroy the window; glfw itself stays up for the next one (terminated at exit)."""
        self.glfw.destroy_window(self.handle)
