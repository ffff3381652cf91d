"""The 3-D view in the browser (viser, imported only here: `pip install "deik[view]"`): a Scene
drawn by viz.viewer_nodes in a scene the user turns, pans and zooms, with a side panel that
states the length unit and the grid's cell, explains the colours, and for a clip or a batch
holds a step slider (scrubbing) and a play/pause button.

`serve` runs the server on this machine until Ctrl-C (KeyboardInterrupt, which it lets through
after stopping the server) or until its `stop` event is set.
"""

from __future__ import annotations

import contextlib
import io
import threading
import time
from collections.abc import Callable
from types import ModuleType

from deik.viz.scene import Scene
from deik.viz.viewer_nodes import SceneNodes

VIEW_HINT = 'the 3-D view needs viser: pip install "deik[view]"'
BATCH_STEP_SECONDS = 0.5  # playing a batch shows each problem this long
LEGEND = (
    "**Colours**: bones and body of the left side crimson, of the right side green, of the middle blue; "
    "joints navy, **root** green, **tips** pink (named; frame axes: x red, y green, z blue), "
    "sites brown, targets red, centre of mass orange, support cyan, contacts olive, obstacles purple, "
    "the compared figure grey."
)


def require_viser() -> ModuleType:
    """The viser module; ImportError with the install command when it is missing."""
    try:
        import viser
    except ImportError:
        raise ImportError(VIEW_HINT) from None
    return viser


def _unit_line(scene: Scene, cell: float) -> str:
    return f"**Lengths** in {scene.unit} ({scene.unit_source}); grid cells {cell:g} {scene.unit}."


class _Player:
    """The step slider and play/pause button of a scene with more than one step."""

    def __init__(self, server, scene: Scene, nodes: SceneNodes):
        self.scene, self.nodes = scene, nodes
        self.seconds = scene.step_time if scene.step == "frame" and scene.step_time else BATCH_STEP_SECONDS
        self.playing = False
        self.started, self.first = 0.0, 0
        last = scene.n_steps - 1
        self.slider = server.gui.add_slider(scene.step, min=0, max=last, step=1, initial_value=0)
        self.time = server.gui.add_markdown(self._time_text(0))
        self.button = server.gui.add_button("Play")
        self.slider.on_update(lambda _: self._moved())
        self.button.on_click(lambda _: self.toggle())

    def _time_text(self, step: int) -> str:
        if self.scene.step == "frame" and self.scene.step_time:
            return f"{self.scene.step} {step} of {self.scene.n_steps}, t = {step * self.scene.step_time:.3f} s"
        return f"{self.scene.step} {step} of {self.scene.n_steps}"

    def _moved(self) -> None:
        step = int(self.slider.value)
        self.nodes.show(step)
        self.time.content = self._time_text(step)

    def toggle(self) -> None:
        """Play from the slider's step, or pause where it is."""
        self.playing = not self.playing
        self.started, self.first = time.monotonic(), int(self.slider.value)
        self.button.label = "Pause" if self.playing else "Play"

    def tick(self) -> None:
        """While playing, put the slider on the step the clock has reached (looping)."""
        if self.playing:
            elapsed = time.monotonic() - self.started
            self.slider.value = (self.first + int(elapsed / self.seconds)) % self.scene.n_steps


def _panel(server, scene: Scene, nodes: SceneNodes) -> _Player | None:
    """The side panel: title, units, notes, legend, toggles and the player."""
    server.gui.add_markdown(f"**{scene.title}**")
    server.gui.add_markdown(_unit_line(scene, nodes.cell))
    for note in scene.notes:
        server.gui.add_markdown(note)
    player = _Player(server, scene, nodes) if scene.n_steps > 1 else None
    if scene.shapes:
        body = server.gui.add_checkbox("body", initial_value=True)
        body.on_update(lambda _: nodes.show_body(body.value))
    names = server.gui.add_checkbox("names", initial_value=True)
    names.on_update(lambda _: nodes.show_names(names.value))
    axes = server.gui.add_checkbox("frame axes", initial_value=nodes.axes_shown)
    axes.on_update(lambda _: nodes.show_axes(axes.value))
    if scene.compare is not None:
        compare = server.gui.add_checkbox(f"compare: {scene.compare.name}", initial_value=True)
        compare.on_update(lambda _: nodes.show_compare(compare.value))
    server.gui.add_markdown(LEGEND)
    return player


def serve(
    scene: Scene,
    host: str = "127.0.0.1",
    port: int = 8080,
    on_ready: Callable[[str], object] | None = None,
    stop: threading.Event | None = None,
) -> None:
    """Serve `scene` at http://host:port (the next free port when that one is taken; 0: any
    free port) until Ctrl-C or `stop` is set; `on_ready(url)` is called once the page can be
    loaded. Ctrl-C's KeyboardInterrupt is raised again after the server has stopped."""
    viser = require_viser()
    with contextlib.redirect_stdout(io.StringIO()):  # viser prints a banner of its own; ours is on_ready's
        server = viser.ViserServer(host=host, port=port, verbose=False)
    try:
        # served to this machine's browser: no button that sends the scene to viser's share service
        server.gui.configure_theme(control_width="large", show_share_button=False)
        nodes = SceneNodes(server, scene)
        player = _panel(server, scene, nodes)
        if on_ready is not None:
            on_ready(f"http://{host}:{server.get_port()}")
        stop = stop or threading.Event()
        while not stop.is_set():
            if player is not None:
                player.tick()
            stop.wait(0.03)
    finally:
        with contextlib.redirect_stdout(io.StringIO()):  # and a line when it stops
            server.stop()
