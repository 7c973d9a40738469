"""The bag survey of ``slamarena data info bag:…`` as a table (:func:`slamarena.datasets.formats.bag_survey.survey`)."""

from __future__ import annotations

__all__ = ["print_survey", "anomaly_text"]


def anomaly_text(anomalies: dict) -> str:
    """One line naming each anomaly of a topic's stamps ('' when none)."""
    parts = []
    if anomalies.get("out_of_order"):
        parts.append(
            f"{anomalies['out_of_order']} out of order (first: message {anomalies['first_out_of_order_index']})"
        )
    if anomalies.get("duplicates"):
        parts.append(f"{anomalies['duplicates']} duplicate stamps")
    if anomalies.get("gaps"):
        parts.append(f"{anomalies['gaps']} gaps (longest {anomalies['longest_gap_s']:.3g} s)")
    if anomalies.get("synthetic"):
        parts.append("perfectly regular: synthetic stamps?")
    if anomalies.get("header_equals_receive"):
        parts.append("header = receive time")
    return "; ".join(parts)


def print_survey(console, name: str) -> dict:
    """Print the topics of the bag dataset ``name`` (``bag:<path>`` or a catalogued bag) and return the survey."""
    from rich.table import Table

    from slamarena.datasets.formats.bag_survey import survey
    from slamarena.datasets.registry import resolve

    report = survey(resolve(name).files()["bag"])
    table = Table(
        title=f"{report['bag']} ({report['kind']}, {report['storage']}): {report['duration_s']:.3f} s "
        f"from {report['t0']!r} s"
    )
    for column in ("topic", "type", "count", "rate [Hz]", "span [s]", "stamps", "anomalies"):
        table.add_column(column)
    for topic, e in report["topics"].items():
        rate = f"{e['rate_hz']:.3f}" if e.get("rate_hz") else "-"
        span = f"{e['span_s']:.3f}" if "span_s" in e else "-"
        table.add_row(topic, e["type"], str(e["count"]), rate, span, e["stamps"], anomaly_text(e.get("anomalies", {})))
    console.print(table)
    return report
