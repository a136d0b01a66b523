"""Tables of results: aligned plain text for the terminal, GitHub markdown for the reports, the
one rule for cells with confidence intervals (:func:`estimate_cell`), and the decision of a
registered reading (:func:`registered_decision`)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

#: Fewer samples than this and a table cell gives its estimate without an interval. From 2 runs
#: a 95 % percentile-bootstrap interval of the mean is just their range (the resampled means
#: take 3 values) and a Student-t one reaches 12.7 standard errors either side; neither means
#: what "95 %" promises.
MIN_SAMPLES_FOR_INTERVAL = 5
#: What such a cell prints instead of the interval.
NO_INTERVAL = f"n < {MIN_SAMPLES_FOR_INTERVAL}: no interval"


def estimate_cell(point: str, interval: str, n: int) -> str:
    """A table cell of an estimate and its confidence interval, or of the estimate alone.

    Every table that prints intervals over seeds goes through here, so that none prints an
    interval from fewer than :data:`MIN_SAMPLES_FOR_INTERVAL` samples.

    Parameters
    ----------
    point : str
        The formatted estimate.
    interval : str
        The formatted interval, e.g. ``"[1.2, 3.4]"`` or ``"± 0.8"``.
    n : int
        Number of samples (seeds) the estimate is computed from.

    Returns
    -------
    str
        ``"point interval"``, or ``"point (n < 5: no interval)"`` (:data:`NO_INTERVAL`) below
        :data:`MIN_SAMPLES_FOR_INTERVAL` samples.
    """
    if n < MIN_SAMPLES_FOR_INTERVAL:
        return f"{point} ({NO_INTERVAL})"
    return f"{point} {interval}"


def format_cell(value: Any) -> str:
    """Render one text-table cell: floats with 4 significant digits, ``None`` as ``-``."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def format_table(rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> str:
    """Left-aligned text table of ``rows`` restricted to ``columns``.

    Parameters
    ----------
    rows : sequence of mappings
        One mapping per row; missing keys print as ``-``.
    columns : sequence of str
        Column keys, also used as headers.

    Returns
    -------
    str
        Header, rule and one line per row.
    """
    cells = [[format_cell(row.get(col)) for col in columns] for row in rows]
    widths = [max([len(col)] + [len(r[i]) for r in cells]) for i, col in enumerate(columns)]
    lines = ["  ".join(col.ljust(w) for col, w in zip(columns, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in cells]
    return "\n".join(lines)


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[str]], align: str = "") -> str:
    """A GitHub markdown table of already formatted cells.

    Parameters
    ----------
    header : sequence of str
        Column titles.
    rows : iterable of sequences of str
        One sequence of cells per row (an empty cell stays empty).
    align : str
        One letter per column, ``"l"`` (left, the default for missing letters) or ``"r"``.

    Returns
    -------
    str
        Header line, alignment rule and one line per row, without a final newline.
    """
    if set(align) - {"l", "r"} or len(align) > len(header):
        raise ValueError(f"align must be at most {len(header)} letters 'l' or 'r', got {align!r}")
    rule = "|" + "".join("---:|" if a == "r" else "---|" for a in align.ljust(len(header), "l"))
    return "\n".join([_markdown_row(header), rule, *(_markdown_row(r) for r in rows)])


def _markdown_row(cells: Sequence[str]) -> str:
    return "| " + " | ".join(cells) + " |"


#: The state of a registered rule whose runs have not all finished.
PARTIAL = "partial: not every run has finished, no decision"


def registered_decision(rules: Sequence[tuple[str, str]], kept: str, adopted: str) -> str:
    """The registered rule's lines and its decision, as markdown.

    Parameters
    ----------
    rules : sequence of (str, str)
        Each rule's text and state: ``"holds"``, ``"fails ..."`` or :data:`PARTIAL`.
    kept, adopted : str
        The decision where a rule fails, and where every rule holds.

    Returns
    -------
    str
        One line per rule, then the decision: ``kept`` where any rule fails (a rule that fails
        on the runs made fails whatever the unfinished ones show), else "partial, nothing
        changes" where a rule is partial, else ``adopted``.
    """
    states = [state for _, state in rules]
    decision = (
        kept if any(s.startswith("fails") for s in states)
        else "partial, nothing changes" if PARTIAL in states
        else adopted
    )  # fmt: skip
    lines = "\n".join(f"- {text}: {state}" for text, state in rules)
    return f"{lines}\n\n**Decision**: {decision}"
