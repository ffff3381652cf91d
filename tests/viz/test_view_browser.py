"""`deik view` in headless Chromium, as a user sees it: the page loads without console errors, the
screenshot shows the skeleton in its colours, left and right apart (and the compared clip, the
targets and the centre of mass), the body's solids fill most of the view on opening (a robot's
meshes, with tool-frame axes sized to it), the frame slider scrubs and the play button plays,
and Ctrl-C stops the command cleanly. Runs on Debian's chromium driven by playwright; skips,
saying so, without them."""

import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import deik
from deik.cli.app import main
from deik.viz.marks import COLOURS
from helpers import ROOT, mesh_robot, readme_commands

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(
    CHROMIUM is None,
    reason="Debian's chromium is not installed (apt-get install chromium): the browser test of `deik view` needs it",
)
sync_api = pytest.importorskip(
    "playwright.sync_api", reason="playwright drives the browser test: pip install playwright"
)
pytest.importorskip("viser", reason='deik view needs viser: pip install "deik[view]"')

# as root, with no GPU and no network: the flags a headless Chromium needs here (software WebGL)
CHROMIUM_FLAGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
COLOUR_DISTANCE = 45  # WebGL renders a colour within this of the one asked for (0-255 RGB)
DEIK = [sys.executable, "-c", "import sys; from deik.cli import main; sys.exit(main())"]


class Viewer:
    """`deik view ARGS` (by default with `--port 0 --no-browser`) in a subprocess, on a machine
    without a display: `line` and `url` once it serves; leaving the block sends Ctrl-C (SIGINT)
    and keeps the exit status and output."""

    def __init__(self, *args, extra=("--port", "0", "--no-browser"), cwd=None):
        hidden = ("DISPLAY", "WAYLAND_DISPLAY", "BROWSER")
        env = {**{k: v for k, v in os.environ.items() if k not in hidden}, "PYTHONPATH": str(ROOT / "src")}
        self.process = subprocess.Popen(
            [*DEIK, "view", *map(str, args), *extra],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=cwd,
            env=env,
        )
        self.line = self.next_line()
        if " at http://" not in self.line:
            self.process.kill()
            raise AssertionError(f"deik view did not start: {self.line!r} {self.process.communicate()[1][-2000:]}")
        self.url = self.line.split(" at ")[1].split()[0]

    def next_line(self, timeout: float = 120) -> str:
        """The next line it prints ("" when none comes within `timeout` seconds)."""
        got = []
        reader = threading.Thread(target=lambda: got.append(self.process.stdout.readline()), daemon=True)
        reader.start()
        reader.join(timeout=timeout)
        return got[0] if got else ""

    def __enter__(self):
        return self

    def __exit__(self, *_):
        self.process.send_signal(signal.SIGINT)
        self.out, self.err = self.process.communicate(timeout=30)
        self.status = self.process.returncode


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as playwright:
        launched = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        yield launched
        launched.close()


def _open(browser, url, body=False):
    """(page, console messages) once the page has connected and drawn the bones; the body's
    solids hidden unless `body` (the bones, joints and marks then show in their own colours)."""
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    console = []
    page.on("console", lambda message: console.append((message.type, message.text)))
    page.on("pageerror", lambda error: console.append(("pageerror", str(error))))
    page.goto(url)
    page.get_by_text("Connected").wait_for(timeout=60_000)
    # a loaded machine's software WebGL may take a while to answer a click
    page.get_by_label("names").uncheck(timeout=120_000)  # labels would cover the marks
    if not body:
        page.get_by_label("body").uncheck(timeout=120_000)
    for _ in range(100):  # until the scene has arrived over the websocket and been drawn
        if _bones(_shot(page)).sum() > 100:
            break
        page.wait_for_timeout(200)
    page.wait_for_timeout(300)
    return page, console


def _shot_until(page, holds, seconds: float = 10.0) -> np.ndarray:
    """The first 3-D view (_shot) for which `holds(shot)` is true, taken every 0.2 s for at most
    `seconds` (the last one then): a loaded machine may draw a change late."""
    deadline = time.monotonic() + seconds
    while True:
        shot = _shot(page)
        if holds(shot) or time.monotonic() > deadline:
            return shot
        page.wait_for_timeout(200)


def _steady_shot(page, holds=lambda shot: True, seconds: float = 20.0) -> np.ndarray:
    """The first 3-D view for which `holds(shot)` is true and that equals the view taken 0.2 s
    before it (within 20 pixels): a loaded machine draws a scene that arrives in parts over a
    few frames, and a picture taken halfway compares wrongly with the next."""
    deadline, before = time.monotonic() + seconds, None
    while True:
        shot = _shot(page)
        steady = before is not None and (np.abs(shot - before).max(axis=-1) > 60).sum() < 20
        if (steady and holds(shot)) or time.monotonic() > deadline:
            return shot
        before = shot
        page.wait_for_timeout(200)


def _shot(page) -> np.ndarray:
    """The 3-D view as (H, W, 3) 0-255 pixels: the side panel and notices painted white, and the
    orientation gizmo's corner cut out."""
    from io import BytesIO

    from matplotlib import image

    covers = [page.locator(".mantine-Paper-root"), page.locator(".mantine-Notification-root")]
    png = page.screenshot(mask=covers, mask_color="#FFFFFF")
    picture = np.round(image.imread(BytesIO(png), format="png")[..., :3] * 255)
    picture[-130:, :130] = 255
    return picture


def _mask(picture, kind) -> np.ndarray:
    return np.linalg.norm(picture - np.array(COLOURS[kind]), axis=-1) < COLOUR_DISTANCE


def _count(picture, kind) -> int:
    return int(_mask(picture, kind).sum())


def _bones(picture) -> np.ndarray:
    """Where bones of the left, right or middle are drawn, in their side's colour."""
    return _mask(picture, "left") | _mask(picture, "right") | _mask(picture, "bone")


def _errors(console):
    return [m for m in console if m[0] in ("error", "pageerror")]


def _walk(path, shift: float, raise_arm: float):
    """A 12-frame clip of the humanoid walking along x, its left arm turning, written as BVH."""
    human = deik.humanoid()
    poses = np.tile(human.reference, (12, 1))
    poses[:, human.dof_names.index("pelvis.Xposition")] += shift * np.arange(12)
    poses[:, human.dof_names.index("left_shoulder.Zrotation")] += raise_arm * np.linspace(0.5, 1, 12)
    deik.write_bvh(path, deik.Clip.from_poses(human, poses, frame_time=1 / 30))
    return path


def test_a_clip_plays_scrubs_and_shows_its_original_in_grey(tmp_path, browser):
    fixed = _walk(tmp_path / "fixed.bvh", 0.08, 1.5)
    original = _walk(tmp_path / "original.bvh", 0.08, -1.0)
    with Viewer(fixed, "--compare", original) as viewer:
        page, console = _open(browser, viewer.url)
        first = _steady_shot(page, lambda shot: _count(shot, "compare") > 100)
        assert _bones(first).sum() > 300 and _count(first, "tip") > 30 and _count(first, "root") > 10
        assert _count(first, "left") > 50 and _count(first, "right") > 50  # each side in its colour
        page.get_by_label("compare: original.bvh").uncheck()
        # the compared figure is the grey one: its pixels go with its box, the clip's bones stay (a
        # share of all changed pixels misjudged it under a loaded suite, where more than it changes)
        gone = lambda shot: (_mask(first, "compare") & ~_mask(shot, "compare")).sum()  # noqa: E731
        without = _steady_shot(page, lambda shot: gone(shot) > 100)
        assert gone(without) > 100 and _bones(without).sum() > 300
        page.get_by_role("textbox").last.fill("9")  # the slider's number box
        page.keyboard.press("Enter")
        page.get_by_text("frame 9 of 12, t = 0.300 s").wait_for()
        before = np.argwhere(_bones(without)).mean(axis=0)
        walked = _shot_until(page, lambda shot: np.linalg.norm(np.argwhere(_bones(shot)).mean(axis=0) - before) > 30)
        assert np.linalg.norm(np.argwhere(_bones(walked)).mean(axis=0) - before) > 30  # the bones walked 0.72 m
        page.get_by_role("button", name="Play").click()
        page.get_by_role("button", name="Pause").wait_for()
        page.wait_for_function("() => !document.body.innerText.includes('frame 9 of 12')", timeout=10_000)
        assert not _errors(console), console
    assert viewer.status == 0 and "deik view: stopped" in viewer.err and "Traceback" not in viewer.err
    assert viewer.line.startswith("deik view: fixed.bvh, 12 frames at http://127.0.0.1:")


def test_a_solved_pose_shows_its_target_and_centre_of_mass(tmp_path, browser):
    human = deik.humanoid()
    rest = deik.forward_kinematics(human, human.reference)
    target = rest.position("left_hand") + [0.3, 0.5, 0.2]
    problem = deik.Problem(human, [deik.Position("left_hand", target, tolerance=0.01)])
    result = deik.solve(problem, population=24, generations=30, seed=1)
    from deik.viz.marks import goal_targets

    pose = tmp_path / "pose.json"
    pose.write_text(json.dumps({**result.to_dict(), "targets": goal_targets(problem), "length_unit": "m"}))
    with Viewer(pose) as viewer:
        page, console = _open(browser, viewer.url)
        picture = _shot(page)
        assert _bones(picture).sum() > 300
        for kind, pixels in (("target", 20), ("centre of mass", 20), ("root", 10), ("tip", 30)):
            assert _count(picture, kind) > pixels, kind
        page.get_by_text(re.compile(r"Lengths in m \(the pose file\); grid cells 0\.[125] m\.")).wait_for()
        assert not _errors(console), console
    assert viewer.status == 0


def _solids(page, shown) -> np.ndarray:
    """Where the body's solids are in the screenshot `shown` (taken with them): the pixels that
    change when the "body" box is unchecked."""
    page.get_by_label("body").uncheck()
    page.wait_for_timeout(700)
    return np.abs(shown - _shot(page)).max(axis=-1) > 40


def test_a_walking_character_opens_on_its_body_filling_the_view(tmp_path, browser):
    """The camera opens on the first frame's body, capsules and all, filling most of the view's
    height without cutting it off, however far the clip walks."""
    clip = _walk(tmp_path / "walk.bvh", 0.15, 0.3)  # 1.65 m along x over the clip
    with Viewer(clip) as viewer:
        page, console = _open(browser, viewer.url, body=True)
        page.get_by_text("body: capsules along the bones, sized from the segment masses").wait_for()
        page.wait_for_timeout(500)
        shown = _shot(page)
        body = _solids(page, shown)
        rows, columns = np.flatnonzero(body.any(axis=1)), np.flatnonzero(body.any(axis=0))
        height, width = body.shape
        assert body.mean() > 0.04  # not an empty picture: the solids cover a good share of it
        assert 0.6 < (rows[-1] - rows[0]) / height < 0.95  # a standing figure most of the view tall
        assert rows[0] > 0 and rows[-1] < height - 1 and columns[0] > 0 and columns[-1] < width - 1
        assert not _errors(console), console


def test_a_robot_shows_its_meshes_and_its_tool_frame_axes(tmp_path, browser):
    path = mesh_robot(tmp_path)
    with Viewer(path) as viewer:
        page, console = _open(browser, viewer.url, body=True)
        page.get_by_text(re.compile(r"body: the URDF's visuals \(mesh x3, box x1\); meshes not found")).wait_for()
        page.wait_for_timeout(500)
        shown = _shot(page)
        assert _solids(page, shown).mean() > 0.03  # its meshes and box, drawn
        assert page.get_by_label("frame axes").is_checked()  # one tool frame: its axes start shown
        with_axes = _shot(page)
        page.get_by_label("frame axes").uncheck()
        page.wait_for_timeout(700)
        axes = np.abs(with_axes - _shot(page)).max(axis=-1) > 60
        assert axes.sum() > 200  # the root's and the tool's axes, big enough to see (their size: test_viewer_nodes)
        assert not _errors(console), console


@pytest.mark.slow  # three browser sessions and a clip fix: 35 s with the machine loaded
@pytest.mark.shared_data
def test_the_readme_view_commands_run_as_written(tmp_path, browser, shared_data, monkeypatch):
    """The README's `deik view` lines (a console block: they serve until Ctrl-C) run as written,
    after the commands of its section that write their files, beside shared/ like a clone."""
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## Seeing results") :]
    section = section[: section.index("\n## ")]
    views = readme_commands(section, "console")
    assert len(views) == 3 and all(v.startswith("deik view ") for v in views)
    clone = tmp_path / "deik"
    clone.mkdir()
    (clone / "out").mkdir()  # as the README's `mkdir -p out` makes it
    (tmp_path / "shared").symlink_to(shared_data.parent)
    monkeypatch.chdir(clone)
    for command in readme_commands(section):  # in this process: tests/cli/test_readme runs them as commands
        assert main(shlex.split(command)[1:]) == 0, command
    for command in views:
        with Viewer(*shlex.split(command)[2:], extra=(), cwd=clone) as viewer:
            assert viewer.next_line(30).startswith("deik view: no browser to open here")
            page, console = _open(browser, viewer.url)
            picture = _shot(page)
            # a met target is drawn where the tip is and may cover its mark: either shows the tip
            tip = _count(picture, "tip") + _count(picture, "target")
            assert _bones(picture).sum() > 100 and tip > 10, command
            assert int(viewer.url.rsplit(":", 1)[1]) >= 8080  # the default port, or the next free one
            # a robot arm starts with its tool frame's axes shown, a character without its many
            assert page.get_by_label("frame axes").is_checked() == ("panda" in command), command
            assert not _errors(console), (command, console)
            page.close()
        assert viewer.status == 0, (command, viewer.err)
