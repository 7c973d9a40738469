"""The VO figures render from a tracks file of the shape ``slamarena bench vision-vo --out`` writes."""

from __future__ import annotations

import json

import numpy as np

from slamarena.paper_figures.vision import plot


def test_vo_figures_render(tmp_path, rng):
    truth = np.cumsum(rng.normal(size=(30, 3)) * [0.1, 0.01, 1.0], axis=0)
    tracks = {
        name: {
            "align": align,
            "estimate": (truth * scale + rng.normal(size=truth.shape) * 0.1).tolist(),
            "truth": truth.tolist(),
            "inliers": [-1, *rng.integers(20, 300, 29).tolist()],
            "keyframes": [0, 5, 11],
        }
        for name, align, scale in (("stereo VO (ours)", "se3", 1.0), ("mono VO (ours)", "sim3", 0.2))
    }
    (tmp_path / "vision_vo_tracks.json").write_text(json.dumps(tracks))
    paths = plot(tmp_path)
    assert {p.name for p in paths} == {
        f"{stem}.{ext}"
        for stem in ("vo_top_view", "vo_error_over_distance", "vo_tracked_features")
        for ext in ("png", "pdf")
    }
    assert all(p.stat().st_size > 1000 for p in paths)
    assert (tmp_path / "vo_top_view.caption").read_text().startswith("Camera positions")
