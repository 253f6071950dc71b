"""Summary of a batch's records (:mod:`clamp.batch.runner`): success rate, failure reasons, times.

Failure reasons are grouped by their wording with the numbers taken out ("collision: minimum
clearance -9.1 mm" and "... -18.8 mm" are one reason); errors by their type, lost problems
as "lost". Times are the plan's own ``timings["total"]`` [s] of the planned problems.
"""
from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from clamp.errors import ClampTypeError, InvalidParameterError
from skillplan.validation import as_instance, as_sequence

_DETAIL = re.compile(r"\s*\([^()]*\d[^()]*\)")         # "(clearance -3.0 mm)"
_LIST = re.compile(r"\[[^\]]*\]")
#: a number standing alone: not the digits of a name such as "j2s6s200_link_finger_2"
_NUMBER = re.compile(r"(?<![\w.])-?\d+(\.\d+)?([eE][-+]?\d+)?")


def reason_key(reason: str) -> str:
    """A reason with its details in parentheses dropped and its numbers (and bracketed lists)
    replaced by "#", for grouping; digits inside names (links, obstacles) are kept."""
    as_instance(reason, "reason", str, "a failure reason (str)", ClampTypeError)
    text = _NUMBER.sub("#", _LIST.sub("[..]", _DETAIL.sub("", reason)))
    return re.sub(r"\s+", " ", text).strip()


def failure_keys(record: dict[str, Any]) -> list[str]:
    """Why a record is not a success: its grouped reasons, its error type, or "lost"."""
    if record["status"] == "lost":
        return ["lost (worker died)"]
    if record["status"] == "error":
        return [f"error: {record['error']['type']}"]
    if record["success"]:
        return []
    return sorted({reason_key(r) for r in record["reasons"]}) or ["failed without a reason"]


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


#: per status, the fields the summary reads: (field, check, what is expected)
_RECORD_FIELDS: dict[str, tuple[tuple[str, Any, str], ...]] = {
    "done": (("success", lambda v: isinstance(v, bool), "true or false"),
             ("reasons", lambda v: isinstance(v, list) and all(isinstance(r, str) for r in v),
              "a list of texts"),
             ("timings", lambda v: isinstance(v, dict) and _number(v.get("total")),
              "an object with a number 'total' [s]")),
    "error": (("error", lambda v: isinstance(v, dict) and isinstance(v.get("type"), str),
               "an object with a text 'type'"),),
    "lost": (),
}


def _check_records(records: Any) -> list[dict[str, Any]]:
    """``records`` as a list of batch records (dicts with a known ``status`` and the fields it
    needs, see clamp.batch.runner); ClampTypeError / InvalidParameterError naming the first bad
    one."""
    records = as_sequence(records, "records", "a list of batch records (dicts, as "
                          "clamp.batch.runner.read_results returns)", ClampTypeError)
    for k, record in enumerate(records):
        as_instance(record, f"records[{k}]", dict, "a batch record (dict)", ClampTypeError)
        status = record.get("status")
        if not isinstance(status, str) or status not in _RECORD_FIELDS:
            raise InvalidParameterError(f"records[{k}].status: expected one of "
                                        f"{sorted(_RECORD_FIELDS)}, got {status!r:.40}")
        for field, ok, expected in _RECORD_FIELDS[status]:
            if not ok(record.get(field)):
                raise InvalidParameterError(f"records[{k}].{field}: expected {expected} in a "
                                            f"{status!r} record, got {record.get(field)!r:.60}")
    return records


def percentile(values: Sequence[float], q: float) -> float:
    return float(np.percentile(values, q)) if len(values) else float("nan")


def summarize(records: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """Counts, success rate (over all records and over those labelled feasible), failure
    reasons (how many records name each), median / p95 plan time [s]."""
    records = _check_records(records)
    status = Counter(r["status"] for r in records)
    success = sum(1 for r in records if r["status"] == "done" and r["success"])
    reasons: Counter[str] = Counter()
    for r in records:
        reasons.update(failure_keys(r))
    times = [r["timings"]["total"] for r in records if r["status"] == "done"]
    feasible = [r for r in records if r.get("expected") == "feasible"]
    impossible = [r for r in records if r.get("expected") == "impossible"]
    return {"problems": len(records), "status": dict(status), "success": success,
            "success_rate": success / len(records) if records else float("nan"),
            "feasible": len(feasible),
            "feasible_success": sum(1 for r in feasible if r["status"] == "done" and r["success"]),
            "impossible": len(impossible),
            "impossible_failed": sum(1 for r in impossible if not r["success"]),
            "reasons": dict(reasons.most_common()),
            "median_s": percentile(times, 50), "p95_s": percentile(times, 95)}


def summary_table(summary: dict[str, Any]) -> str:
    """Plain-text table of :func:`summarize`'s figures."""
    as_instance(summary, "summary", dict, "the dict clamp.batch.report.summarize returns",
                ClampTypeError)
    missing = sorted(set(summarize([])) - set(summary))
    if missing:
        raise InvalidParameterError(f"summary: expected the dict summarize returns, missing "
                                    f"{missing}")
    n = summary["problems"]
    status = ", ".join(f"{k} {v}" for k, v in sorted(summary["status"].items()))
    rate = f"  ({100 * summary['success_rate']:.1f} %)" if n else ""
    lines = [f"problems          {n}  ({status})" if n else "problems          0",
             f"success           {summary['success']} / {n}{rate}"]
    if summary["feasible"]:
        lines.append(f"feasible solved   {summary['feasible_success']} / {summary['feasible']}  "
                     f"({100 * summary['feasible_success'] / summary['feasible']:.1f} %)")
    if summary["impossible"]:
        lines.append(f"impossible failed {summary['impossible_failed']} / {summary['impossible']}")
    if np.isfinite(summary["median_s"]):
        lines.append(f"plan time         median {1e3 * summary['median_s']:.1f} ms, "
                     f"p95 {1e3 * summary['p95_s']:.1f} ms")
    if summary["reasons"]:
        lines.append("failure reasons (problems naming each):")
        lines += [f"  {count:6d}  {key}" for key, count in summary["reasons"].items()]
    return "\n".join(lines)
