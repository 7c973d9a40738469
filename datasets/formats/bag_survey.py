"""What a ROS bag holds, per topic, and what is odd about its stamps (for ``slamarena data info bag:PATH``).

Per topic: type, count, rate ``(n − 1)/(t_last − t_first)``, time span, the stamp source (``header`` when every
message has a ``header.stamp``, else ``receive``) and anomalies of those stamps, in bag order:

* ``out_of_order``: messages stamped earlier than the one before (first index given); the reader refuses them;
* ``duplicates``: messages stamped the same as the one before;
* ``gaps``: steps longer than ``GAP_FACTOR`` × the median step (the longest given);
* ``synthetic``: at least ``SYNTHETIC_MIN`` messages whose steps all equal the median within ``SYNTHETIC_TOL_NS`` ns
  (a real clock jitters by microseconds at least; a converter that writes ``t0 + k·T`` does not), and
  ``header_equals_receive`` when every header stamp equals its receive time within 1 µs (a live recorder
  receives a message after it is stamped).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .bag_io import bag_location, open_bag, read_topic

__all__ = ["survey", "stamp_anomalies", "GAP_FACTOR", "SYNTHETIC_MIN", "SYNTHETIC_TOL_NS"]

GAP_FACTOR = 5.0
SYNTHETIC_MIN = 10
SYNTHETIC_TOL_NS = 1000


def stamp_anomalies(t_ns: np.ndarray) -> dict:
    """The anomalies of stamps ``t_ns`` (integer nanoseconds, bag order), see the module docstring."""
    d = np.diff(np.asarray(t_ns, dtype=np.int64))
    out: dict = {"out_of_order": int((d < 0).sum()), "duplicates": int((d == 0).sum())}
    if out["out_of_order"]:
        out["first_out_of_order_index"] = int(np.flatnonzero(d < 0)[0]) + 1
    forward = d[d > 0]
    median = float(np.median(forward)) if forward.size else None
    gaps = forward[forward > GAP_FACTOR * median] if median else forward[:0]
    out["gaps"] = int(gaps.size)
    if gaps.size:
        out["longest_gap_s"] = float(gaps.max()) * 1e-9
    out["synthetic"] = bool(
        t_ns.size >= SYNTHETIC_MIN and median is not None and np.all(np.abs(d - median) <= SYNTHETIC_TOL_NS)
    )
    return out


def survey(path: str | Path) -> dict:
    """Bag kind, time span and per-topic entries (module docstring) of the bag at ``path``."""
    bag = bag_location(path)
    topics = {}
    with open_bag(bag) as reader:
        kind = "ROS 2" if reader.is2 else "ROS 1"
        mcap = bag.suffix == ".mcap" or (bag.is_dir() and any(bag.glob("*.mcap")))
        storage = "bag format 2.0" if not reader.is2 else ("MCAP" if mcap else "sqlite3")
        for topic in sorted({c.topic for c in reader.connections}):
            messages = read_topic(reader, topic)
            header = messages.header_ns is not None and len(messages) > 0
            t_ns = messages.header_ns if header else messages.receive_ns
            t = t_ns / 1e9
            entry = {"type": messages.msgtype, "count": len(messages), "stamps": "header" if header else "receive"}
            if len(messages):
                entry.update(t0=float(t[0]), t1=float(t[-1]), span_s=float(t.max() - t.min()))
                entry["rate_hz"] = (len(t) - 1) / entry["span_s"] if entry["span_s"] > 0 else None
                entry["anomalies"] = stamp_anomalies(t_ns)
                if header:
                    entry["anomalies"]["header_equals_receive"] = bool(
                        np.all(np.abs(messages.header_ns - messages.receive_ns) <= 1000)
                    )
            topics[topic] = entry
    starts = [e["t0"] for e in topics.values() if "t0" in e]
    ends = [e["t1"] for e in topics.values() if "t1" in e]
    return {
        "bag": str(bag),
        "kind": kind,
        "storage": storage,
        "t0": min(starts) if starts else None,
        "t1": max(ends) if ends else None,
        "duration_s": (max(ends) - min(starts)) if starts else 0.0,
        "topics": topics,
    }
