"""Clips of a recorded run: a :class:`stackdsl.Trajectory` as a GIF or an MP4.

A clip runs from the first placement to the end of the run (2 s after a collapse). While
anything moves (the recorder's frames are 1/30 s apart) it plays in real time; each quiet
stretch between two placements is cut to at most :data:`QUIET_HOLD` seconds of clip; and when
that is still more than ``max_frames`` frames, the whole clip is sped up evenly. The frames of
a launch, every impact (a blow that wakes a brick included), the collapse and the middle of each
throw's flight are always drawn (:func:`key_frames`), put in where the clip would pass them. Every frame carries the simulated time
and the speed-up (``t = 12.30 s  x4``), a legend of the state colours and a scale bar.

Pictures come from :class:`stackdsl.draw.render.Scene` (a numpy z-buffer); a GIF is written
by Pillow with one fixed palette, an MP4 (H.264) by the ffmpeg of the ``imageio-ffmpeg`` package.

>>> import stackdsl
>>> from stackdsl.runtime.recorder import record_program
>>> program = stackdsl.compile_scenario(stackdsl.parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}"))
>>> outcome, trajectory = record_program(program)
>>> plan = timeline(trajectory)
>>> round(float(plan.times[0]), 2), round(float(plan.times[-1]), 2), len(plan.frames) < 60
(0.0, 5.0, True)

Source: stackdsl's own.
"""

from __future__ import annotations

import errno
import math
import os
import shutil
import time as _time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from ..lang.errors import ScenarioError
from ..runtime.trajectory import STATES, Trajectory
from ..util.extras import installed, missing
from ..util.files import written
from .render import COLOURS, LABELS, Scene, collapse_text, legend_keys, scale_bar

#: Frames a second of a clip, by default.
FPS = 30.0
#: At most this many frames (the clip is sped up evenly to fit), by default: 20 s at 30 frames a second.
MAX_FRAMES = 600
#: Seconds of clip a quiet stretch (nothing moves, e.g. the wait between two placements) lasts at most.
QUIET_HOLD = 0.1
#: Seconds the last picture stays on before the clip ends (or a GIF starts again).
END_HOLD = 1.0
#: Events whose frames every clip draws.
KEY_EVENTS = ("launch", "impact", "collapse")
#: A GIF's frame times are whole hundredths of a second, and players slow down shorter ones than 0.02 s.
GIF_MAX_FPS = 50.0


@dataclass(frozen=True)
class Timeline:
    """What each frame of a clip shows.

    Attributes:
        frames: (n,) the trajectory frame drawn, non-decreasing.
        times: (n,) the simulated time shown, seconds, increasing.
        speeds: (n,) the speed-up: simulated seconds a second of clip (1: real time).
    """

    frames: np.ndarray
    times: np.ndarray
    speeds: np.ndarray


def timeline(trajectory: Trajectory, fps: float = FPS, max_frames: int = MAX_FRAMES) -> Timeline:
    """The frames of a clip of ``trajectory`` at ``fps`` frames a second.

    The recorded frames fall into bursts (frames at most 1.5 recording intervals apart: something
    moves) and the quiet stretches between them. A burst is drawn in real time from its first
    frame on (a placement, a launch); a quiet stretch gets at most :data:`QUIET_HOLD` seconds of
    clip, never less than real time; the clip ends on the run's last frame (a 0.05 s run at 30
    frames a second drew 0 and 0.03 s). When that makes more than ``max_frames`` frames, everything
    is sped up by the least even factor that fits (and when one frame a burst is still too many,
    frames are dropped evenly). The frames of :func:`key_frames` are put in even when mid-burst
    (``max_frames`` is kept by dropping others).

    Raises:
        ValueError: ``fps`` not above 0; ``max_frames`` below 2; a trajectory with no frame.
    """
    if not (isinstance(fps, (int, float)) and 0 < fps < math.inf):
        raise ValueError(f"a clip needs a number of frames a second above 0, not {fps!r}")
    if max_frames < 2:
        raise ValueError(f"a clip needs at least 2 frames, not {max_frames}")
    times = trajectory.times
    if not len(times):
        raise ValueError("the trajectory has no frame")
    quiet = np.diff(times) > 1.5 / float(trajectory.meta.get("rate") or 30.0)
    first, last = np.r_[0, np.flatnonzero(quiet) + 1], np.r_[np.flatnonzero(quiet), len(times) - 1]  # of each burst
    lengths, pauses = times[last] - times[first], times[first[1:]] - times[last[:-1]]  # s

    def counts(speed: float) -> tuple[np.ndarray, np.ndarray]:  # frames of each burst and each pause
        burst = np.floor(lengths * fps / speed + 1e-9).astype(int) + 1
        hold = np.minimum(np.round(QUIET_HOLD * fps / speed), np.floor(pauses * fps / speed + 1e-9) - 1)
        return burst, hold.clip(0).astype(int)

    speed, slowest, fastest = 1.0, 1.0, max(2.0, float(times[-1] - times[0]) * fps)
    if sum(map(int, map(np.sum, counts(speed)))) > max_frames:
        for _ in range(60):  # bisection, on a log scale, for the least speed-up that fits
            speed = math.sqrt(slowest * fastest)
            slowest, fastest = (speed, fastest) if sum(map(int, map(np.sum, counts(speed)))) > max_frames else (slowest, speed)
        speed = fastest
    burst, hold = counts(speed)
    at, rate, still = [], [], []  # each clip frame: simulated time, speed-up, in a quiet stretch
    for b, start in enumerate(times[first]):
        at.append(start + np.arange(burst[b]) * speed / fps)
        rate.append(np.full(burst[b], speed))
        still.append(np.zeros(burst[b], bool))
        if b < len(pauses) and hold[b]:
            at.append(times[last[b]] + pauses[b] * np.arange(1, hold[b] + 1) / (hold[b] + 1))
            rate.append(np.full(hold[b], pauses[b] * fps / (hold[b] + 1)))
            still.append(np.ones(hold[b], bool))
    shown, speeds, stills = np.concatenate(at), np.concatenate(rate), np.concatenate(still)
    if shown[-1] < times[-1] - 1e-9:  # the last burst's frames stopped short of its end: the run's end is drawn
        shown, speeds, stills = np.append(shown, times[-1]), np.append(speeds, speeds[-1]), np.append(stills, False)
    if len(shown) > max_frames:  # more bursts than frames: drop frames evenly, keep the first and last
        keep = np.unique(np.round(np.linspace(0, len(shown) - 1, max_frames)).astype(int))
        shown, speeds, stills = shown[keep], speeds[keep] * len(shown) / len(keep), stills[keep]
    before = np.clip(np.searchsorted(times, shown + 1e-9, side="right") - 1, 0, len(times) - 1)
    after = np.minimum(before + 1, len(times) - 1)
    nearer = ~stills & (times[after] - shown < shown - times[before])  # a burst shows its nearest frame
    frames = np.where(nearer, after, before)
    frames, shown, speeds = _with_key_frames(trajectory, frames, shown, speeds, max_frames)
    return Timeline(frames, shown, speeds)


def key_frames(trajectory: Trajectory) -> list[int]:
    """The recorded frames every clip draws, ascending: those of each launch, impact (a held
    one, or a brick woken by a blow: a ``wake`` whose reason is an impact) and the collapse, and
    for each launch the frame nearest the middle of its flight to the first hit after it, when
    one lies strictly between (a throw at 5 m/s crosses 50 mm in 10 ms, less than a frame of a
    clip at 30 frames a second)."""
    events = trajectory.events
    hits = sorted(e.time for e in events if e.kind == "impact" or (e.kind == "wake" and e.detail.startswith("impact of")))
    keys = {trajectory.frame_index(e.time) for e in events if e.kind in KEY_EVENTS} | {trajectory.frame_index(t) for t in hits}
    for launch in (e.time for e in events if e.kind == "launch"):
        hit = next((t for t in hits if t > launch), None)
        if hit is None:
            continue
        middle = int(np.argmin(np.abs(trajectory.times - (launch + hit) / 2)))
        if launch < trajectory.times[middle] < hit:
            keys.add(middle)
    return sorted(keys)


def _with_key_frames(
    trajectory: Trajectory, frames: np.ndarray, shown: np.ndarray, speeds: np.ndarray, max_frames: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The clip's frames with every :func:`key_frames` frame put in where it is missing (at
    its own time, or between its neighbours' when theirs are too close); past ``max_frames``,
    other frames (never the first, the last or a key one) are dropped evenly."""
    times = trajectory.times
    keys = key_frames(trajectory)
    for index in keys:
        if index in frames:
            continue
        at = int(np.searchsorted(frames, index, side="right"))  # frames stay non-decreasing
        low = shown[at - 1] if at else -math.inf
        high = shown[at] if at < len(shown) else math.inf
        time = float(times[index])
        if not low < time < high:  # keep the clip's times increasing
            time = (low + high) / 2 if math.isfinite(low) and math.isfinite(high) else (high - 1e-6 if at == 0 else low + 1e-6)
        speed = speeds[min(at, len(speeds) - 1)]
        frames, shown, speeds = np.insert(frames, at, index), np.insert(shown, at, time), np.insert(speeds, at, speed)
    if len(frames) > max_frames:
        fixed = np.isin(frames, keys)
        fixed[[0, -1]] = True
        loose = np.flatnonzero(~fixed)
        drop = loose[np.round(np.linspace(0, len(loose) - 1, min(len(frames) - max_frames, len(loose)))).astype(int)]
        keep = np.setdiff1d(np.arange(len(frames)), drop)
        frames, shown, speeds = frames[keep], shown[keep], speeds[keep] * len(frames) / len(keep)
    return frames, shown, speeds


def speed_text(speed: float) -> str:
    """``x1``, ``x2.5``, ``x28``: a speed-up as the clip shows it."""
    return f"x{round(speed)}" if speed >= 9.95 else f"x{speed:.1f}".removesuffix(".0")


def _font(size: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    """Pillow's TrueType DejaVu Sans (matplotlib ships it) at ``size`` pixels."""
    from matplotlib import font_manager

    try:
        return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size)
    except OSError:  # pragma: no cover - matplotlib always ships DejaVu Sans
        return ImageFont.load_default()


class _Overlay:
    """Draws the time, speed-up, legend and scale bar on each picture of a clip."""

    def __init__(self, trajectory: Trajectory, width: int, height: int, pixels_per_metre: float) -> None:
        self.width, self.height = width, height
        self.big, self.small = _font(max(10, height // 24)), _font(max(8, height // 32))
        self.bar = scale_bar(pixels_per_metre, width)
        self.length = self.bar[0] * pixels_per_metre
        projectile = trajectory.projectiles[trajectory.row_body]
        seen = {"projectile" if p else STATES[s] for p, s in zip(projectile, trajectory.row_state)}
        self.keys = legend_keys(trajectory, seen)
        meta = trajectory.meta
        engine = " ".join(str(meta[k]) for k in ("backend", "mode") if meta.get(k)) or "?"
        self.name = f"{meta.get('scenario') or meta.get('file') or 'run'} · {engine}"
        collapse = meta.get("collapse")
        self.collapse = None if collapse is None else (float(collapse["time"]), collapse_text(collapse))

    def draw(self, image: np.ndarray, time: float, speed: float) -> np.ndarray:
        picture = Image.fromarray(image)
        draw = ImageDraw.Draw(picture, "RGBA")
        pad, line = 4, self.height // 22 + 4
        text = f"t = {time:5.2f} s  {speed_text(speed)}"
        draw.rectangle((0, 0, draw.textlength(text, font=self.big) + 2 * pad, 2 * line + pad), fill=(255, 255, 255, 190))
        draw.text((pad, pad), text, fill=(0, 0, 0), font=self.big)
        draw.text((pad, pad + line), self.name, fill=(40, 40, 40), font=self.small)
        if self.collapse is not None and time >= self.collapse[0]:
            draw.text((pad, pad + 2 * line), self.collapse[1], fill=(200, 20, 20), font=self.small)
        box = max(8, self.height // 40)
        for i, key in enumerate(self.keys):  # the legend, top right
            right, top = self.width - pad, pad + i * (box + 4)
            label = LABELS.get(key, key)
            width = draw.textlength(label, font=self.small)
            draw.rectangle((right - width - box - 2 * pad, top - 2, right, top + box + 2), fill=(255, 255, 255, 190))
            draw.rectangle((right - box, top, right, top + box), fill=_rgb(COLOURS[key]), outline=(60, 60, 60))
            draw.text((right - box - pad, top + box / 2), label, fill=(0, 0, 0), font=self.small, anchor="rm")
        left, bottom = 0.04 * self.width, self.height - 0.05 * self.height
        draw.rectangle((left, bottom - 3, left + self.length, bottom), fill=(0, 0, 0))
        draw.text((left + self.length / 2, bottom - 5), self.bar[1], fill=(0, 0, 0), font=self.small, anchor="mb")
        return np.asarray(picture)


def _rgb(colour: tuple[float, float, float]) -> tuple[int, int, int]:
    r, g, b = (round(255 * c) for c in colour)
    return r, g, b


def _palette() -> Image.Image:
    """A fixed GIF palette: every colour of :data:`COLOURS` from dark to light, and greys."""
    shades = [np.clip(np.array(c) * k, 0.0, 1.0) for c in COLOURS.values() for k in np.linspace(0.3, 1.1, 24)]
    shades += [np.full(3, g) for g in np.linspace(0.0, 1.0, 256 - len(shades))]
    palette = Image.new("P", (1, 1))
    palette.putpalette((np.round(np.array(shades) * 255).astype(np.uint8)).ravel().tolist())
    return palette


def _pictures(scene: Scene, plan: Timeline, deadline: float | None = None) -> Iterator[np.ndarray]:
    """The clip's pictures, (height, width, 3) uint8, one per frame of ``plan``; each
    trajectory frame is rendered once. TimeoutError past ``deadline`` (``time.perf_counter()``
    seconds; None: none)."""
    trajectory = scene.trajectory
    overlay = _Overlay(trajectory, scene.width, scene.height, scene.camera.pixels_per_metre)
    renders = ((f.index, scene.render(f)) for f in trajectory.frames(sorted(set(plan.frames.tolist()))))
    current, image = -1, np.zeros((scene.height, scene.width, 3), np.uint8)
    for index, time, speed in zip(plan.frames.tolist(), plan.times, plan.speeds):
        if deadline is not None and _time.perf_counter() > deadline:
            raise TimeoutError("drawing the clip passed --timeout")
        while current != index:  # plan.frames never decreases
            current, image = next(renders)
        yield overlay.draw(image, float(time), float(speed))


def animate(
    trajectory: Trajectory,
    path: str | os.PathLike[str],
    *,
    fps: float = FPS,
    width: int = 480,
    height: int = 360,
    max_frames: int = MAX_FRAMES,
    deadline: float | None = None,
) -> Timeline:
    """Write a clip of ``trajectory`` at ``path``: ``.gif`` (Pillow) or ``.mp4`` (H.264 by
    imageio-ffmpeg's ffmpeg), ``width`` x ``height`` pixels at ``fps`` frames a second, its
    frames chosen by :func:`timeline`; the last picture stays :data:`END_HOLD` seconds.
    Returns the timeline drawn. The file is written under a temporary name and renamed
    when complete (:func:`stackdsl.util.files.written`).

    Raises:
        ValueError: another suffix; ``fps`` not above 0 (above :data:`GIF_MAX_FPS` for a GIF);
            ``max_frames`` below 2; a picture smaller than 16 x 16 pixels; no frame; more
            than :data:`MAX_PIXEL_WORK` pixels to draw (:func:`pixel_work`).
        TimeoutError: past ``deadline`` (``time.perf_counter()`` seconds; None: none).
        OSError: the file cannot be written (ffmpeg failing included: ``No space left on device``
            when its disk is full, else an input/output error; either names ``path``).
    """
    suffix = Path(path).suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise ValueError(f"a clip is written as .gif or .mp4, not {Path(path).name!r}")
    if suffix == ".gif" and isinstance(fps, (int, float)) and fps > GIF_MAX_FPS:
        raise ValueError(f"a GIF plays at most {GIF_MAX_FPS:g} frames a second, not {fps:g}")
    plan = timeline(trajectory, fps, max_frames)
    check_pixel_work(width, height, len(plan.frames), fps)
    with Scene(trajectory, width, height) as scene, written(path) as part:  # the scene first: it checks the size
        if suffix == ".gif":
            _write_gif(_pictures(scene, plan, deadline), part, fps, len(plan.frames))
        else:
            _write_mp4(_pictures(scene, plan, deadline), part, fps, width, height)
    return plan


#: Pixels a clip may draw, frames times width times height (about 40 s of drawing on one core):
#: a 4096 x 4096 clip at 120 frames a second would be 10^10, minutes of drawing and encoding.
MAX_PIXEL_WORK = 1.5e9


def pixel_work(width: int, height: int, frames: int, fps: float) -> float:
    """Pixels a clip of ``frames`` frames of ``width`` x ``height`` draws, its end hold included."""
    return float(width) * height * (frames + round(END_HOLD * fps))


def check_pixel_work(width: int, height: int, frames: int, fps: float) -> None:
    """Refuse a clip above :data:`MAX_PIXEL_WORK` pixels.

    Raises:
        ValueError: naming the work and the cap.
    """
    work = pixel_work(width, height, frames, fps)
    if work > MAX_PIXEL_WORK:
        raise ValueError(
            f"{frames} frames of {width} x {height} pixels are {work:.3g} pixels to draw; at most {MAX_PIXEL_WORK:.3g}: "
            "give a smaller --size or fewer --fps"
        )


def _write_gif(pictures: Iterator[np.ndarray], path: Path, fps: float, count: int) -> None:
    palette = _palette()
    frames = (Image.fromarray(p).quantize(palette=palette, dither=Image.Dither.NONE) for p in pictures)
    ticks = np.round(np.arange(count + 1) * 100.0 / fps)  # hundredths of a second, so that the frames average 1 / fps
    durations = (np.diff(ticks) * 10).astype(int)
    durations[-1] += round(END_HOLD * 1000)
    first = next(frames)
    first.save(path, save_all=True, append_images=frames, duration=durations.tolist(), loop=0, optimize=False)


def _write_mp4(pictures: Iterator[np.ndarray], path: Path, fps: float, width: int, height: int) -> None:
    if not installed("video"):
        raise ScenarioError(missing("video", "an MP4 clip"), file=str(path))
    import imageio_ffmpeg

    even = (width + width % 2, height + height % 2)  # H.264 in yuv420p needs even sides
    pad = ((0, even[1] - height), (0, even[0] - width), (0, 0))
    # ffmpeg says nothing itself (a failure is one line of ours), and its exit status is not
    # passed on: a clip it could not finish (a full disk: "Error writing trailer") is found by
    # reading the file's boxes
    writer = imageio_ffmpeg.write_frames(
        str(path), even, fps=fps, codec="libx264", pix_fmt_out="yuv420p", macro_block_size=2, ffmpeg_log_level="quiet"
    )
    writer.send(None)
    try:
        last = np.zeros((even[1], even[0], 3), np.uint8)
        for picture in pictures:
            last = np.ascontiguousarray(np.pad(picture, pad, mode="edge"))
            writer.send(last)
        for _ in range(round(END_HOLD * fps)):
            writer.send(last)
    except (OSError, RuntimeError):  # ffmpeg went away (imageio's message holds its command line)
        writer.close()
        raise _ffmpeg_failed(path) from None
    writer.close()
    if not complete_mp4(path):
        raise _ffmpeg_failed(path)


#: Bytes free on a disk under which a clip ffmpeg could not finish is said to have filled it.
FULL_DISK = 1 << 20


def _ffmpeg_failed(path: Path) -> OSError:
    """The error of a clip ffmpeg could not write: "No space left on device" when its disk has
    (almost) none left, else an input/output error; ``path`` named (the temporary name is replaced
    by the final one)."""
    try:
        full = shutil.disk_usage(path.parent).free < FULL_DISK
    except OSError:
        full = False
    if full:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    return OSError(errno.EIO, "ffmpeg could not write the whole clip", str(path))


def complete_mp4(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is an MP4 file whose top-level boxes fill it exactly, with its movie
    header (``moov``, which ffmpeg writes last) and its media data (``mdat``).

    >>> import tempfile
    >>> box = lambda kind, body=b"": (8 + len(body)).to_bytes(4, "big") + kind + body
    >>> with tempfile.NamedTemporaryFile(suffix=".mp4") as f:
    ...     _ = f.write(box(b"ftyp", b"isom") + box(b"mdat", b"x" * 9)); f.flush(); before = complete_mp4(f.name)
    ...     _ = f.write(box(b"moov", b"y" * 3)); f.flush(); after = complete_mp4(f.name)
    >>> before, after
    (False, True)
    """
    kinds = set()
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            at = 0
            while at < size:
                f.seek(at)
                head = f.read(16)
                if len(head) < 8:
                    return False
                length, kind = int.from_bytes(head[:4], "big"), head[4:8]
                if length == 1:  # a 64-bit length follows
                    length = int.from_bytes(head[8:16], "big") if len(head) == 16 else 0
                elif length == 0:  # to the end of the file
                    length = size - at
                if length < 8 or at + length > size:
                    return False
                kinds.add(kind)
                at += length
    except OSError:
        return False
    return b"moov" in kinds and b"mdat" in kinds
