"""Same-place groups on the shared data: what the rule finds, what it changes, what it costs.

``python benchmarks/bench_same_place.py`` prints, for every traversal of
``../shared/data`` (Nordland summer and winter, Gardens Point's three walks):

- the distribution of the rule's measure (mean absolute difference of consecutive 16x16
  normalised thumbnails) over consecutive seen frames, and how many frames are not seen;
- the groups the ``still-frames`` rule finds (count, frames, ranges);
- the same groups on degraded copies (4x upsampled, 64x32, JPEG quality 75 and 30, grey
  noise of 3 levels), to show the rule does not hang on resolution or compression;
- for every pair the loaders offer, how many queries' accepted sets the closure changes;
- the cost per frame of the thumbnails (reduced JPEG decode, and a full decode for
  comparison) and the peak memory of the rule over a 30,000-frame traversal.

The figures in docs/datasets.md ("Same-place groups") come from this script.
"""

from __future__ import annotations

import io
import itertools
import statistics
import time
import tracemalloc
from pathlib import Path

import numpy as np
from PIL import Image

from ppaloc.datasets import load_dataset
from ppaloc.datasets.frames import ImageFrames, RenderedFrames
from ppaloc.datasets.images import list_images, read_grey
from ppaloc.datasets.sameplace import STILL_FRAMES, still_groups, thumbnail, thumbnails

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"
TRAVERSALS = {
    "nordland summer": SHARED / "nordland-64x32" / "summer",
    "nordland winter": SHARED / "nordland-64x32" / "winter",
    "gardens-point day_left": SHARED / "gardens-point" / "day_left",
    "gardens-point day_right": SHARED / "gardens-point" / "day_right",
    "gardens-point night_right": SHARED / "gardens-point" / "night_right",
}
PAIRS = [
    "nordland:{root}/nordland-64x32?ref=summer&query=winter",
    "nordland:{root}/nordland-64x32?ref=summer&query=winter&tolerance=2",
    "nordland:{root}/nordland-64x32?ref=winter&query=summer",
    "gardens-point:{root}/gardens-point?ref=day_left&query=day_right",
    "gardens-point:{root}/gardens-point?ref=day_right&query=night_right",
    "gardens-point:{root}/gardens-point?ref=day_left&query=night_right",
]


def _ranges(groups: np.ndarray) -> str:
    return " ".join(f"{a}-{b - 1}" for a, b in groups)


def _count(groups: np.ndarray) -> tuple[int, int]:
    return len(groups), int((groups[:, 1] - groups[:, 0]).sum())


def _measure(thumbs: list[np.ndarray]) -> tuple[np.ndarray, int]:
    """Consecutive differences of seen frames, and how many frames are not seen."""
    rule = STILL_FRAMES
    z = []
    for t in thumbs:
        t = t.astype(np.float64)
        seen = t.mean() >= rule.min_mean and t.std() >= rule.min_std
        z.append((t - t.mean()) / t.std() if seen else None)
    d = [
        float(np.abs(a - b).mean())
        for a, b in itertools.pairwise(z)
        if a is not None and b is not None
    ]
    return np.array(d), sum(v is None for v in z)


def _jpeg(frame: np.ndarray, quality: int) -> np.ndarray:
    buf = io.BytesIO()
    Image.fromarray(frame).save(buf, "JPEG", quality=quality)
    buf.seek(0)
    return np.asarray(Image.open(buf).convert("L"))


def groups_report() -> None:
    noise = np.random.default_rng(0)
    variants = {
        "x4": lambda f: np.asarray(
            Image.fromarray(f).resize((f.shape[1] * 4, f.shape[0] * 4), Image.Resampling.BILINEAR)
        ),
        "64x32": lambda f: np.asarray(
            Image.fromarray(f).resize((64, 32), Image.Resampling.BILINEAR)
        ),
        "jpeg75": lambda f: _jpeg(f, 75),
        "jpeg30": lambda f: _jpeg(f, 30),
        "noise3": lambda f: np.clip(f + noise.normal(0, 3, f.shape), 0, 255).astype(np.uint8),
    }
    for name, folder in TRAVERSALS.items():
        if not folder.is_dir():
            print(f"{name}: absent")
            continue
        frames = ImageFrames(list_images(folder))
        thumbs = list(thumbnails(frames))
        d, unseen = _measure(thumbs)
        groups = still_groups(thumbs)
        g, f = _count(groups)
        pct = np.percentile(d, [1, 10, 50]) if d.size else [np.nan] * 3
        print(
            f"{name}: {len(frames)} frames, {unseen} not seen; consecutive differences of seen "
            f"frames: {np.mean(d <= 0.05):.1%} <= 0.05, {np.mean((d > 0.05) & (d <= 0.15)):.1%} "
            f"in (0.05, 0.15], {np.mean(d > 0.15):.1%} > 0.15; min {d.min():.3f}, "
            f"1/10/50th percentiles {pct[0]:.3f} {pct[1]:.3f} {pct[2]:.3f}"
        )
        print(f"  {g} groups, {f} frames ({f / len(frames):.1%}): {_ranges(groups)}")
        greys = [read_grey(p) for p in frames.paths]
        shown = []
        for label, fn in variants.items():
            other = still_groups(thumbnail(fn(x)) for x in greys)
            same = other.shape == groups.shape and bool((other == groups).all())
            shown.append(f"{label} {_count(other)[0]}/{_count(other)[1]}{' same' if same else ''}")
        print("  degraded (groups/frames): " + ", ".join(shown))


def closure_report() -> None:
    for spec in PAIRS:
        spec = spec.format(root=SHARED)
        try:
            ds = load_dataset(spec)
        except Exception as exc:  # absent data
            print(f"{spec}: {exc}")
            continue
        rule = ds.meta["ground_truth_rule"]["same_place"]
        off = load_dataset(spec + "&same_place=off")
        sizes = [len(g) for g in ds.ground_truth]
        before = [len(g) for g in off.ground_truth]
        print(
            f"{spec.split('/')[-1]}: {rule['groups']} groups, {rule['queries_changed']} of "
            f"{len(ds.query)} queries' accepted sets changed; mean set size "
            f"{statistics.mean(before):.2f} -> {statistics.mean(sizes):.2f}"
        )


def cost_report() -> None:
    """CPU time per frame (the machine may be shared: wall clock would count waiting)."""
    for name in ("nordland summer", "gardens-point day_right"):
        folder = TRAVERSALS[name]
        if not folder.is_dir():
            continue
        frames = ImageFrames(list_images(folder))
        t0 = time.process_time()
        list(thumbnails(frames))
        fast = (time.process_time() - t0) / len(frames) * 1e3
        t0 = time.process_time()
        for p in frames.paths:
            thumbnail(read_grey(p))
        full = (time.process_time() - t0) / len(frames) * 1e3
        print(
            f"{name}: {fast:.2f} ms/frame CPU (reduced decode), {full:.2f} ms/frame (full "
            f"decode); 30,000 such frames: {fast * 30:.0f} s"
        )
    rng = np.random.default_rng(1)
    # eight smooth 128x128 scenes (seen by the rule), each held for 40 frames: a stop
    coarse = rng.uniform(0, 255, (8, 8, 8)).astype(np.float32)
    scenes = [
        np.asarray(Image.fromarray(c, mode="F").resize((128, 128), Image.Resampling.BILINEAR))
        .clip(0, 255)
        .astype(np.uint8)
        for c in coarse
    ]
    for n in (3_000, 30_000):
        frames = RenderedFrames(lambda i: scenes[(i // 40) % 8], n, cache=0)
        tracemalloc.start()
        t0 = time.process_time()
        groups = still_groups(thumbnails(frames))
        took = time.process_time() - t0
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        print(
            f"{n} frames of 128x128 held 40 frames each: {len(groups)} groups in {took:.1f} s CPU; "
            f"peak memory traced while finding them {peak / 2**10:.0f} KiB"
        )


if __name__ == "__main__":
    groups_report()
    closure_report()
    cost_report()
