"""The verdict of ``ctrlblocks compare``: winners with a tie band, and sentences with their numbers.

``winners(summary)`` gives, for the set-point step (``iae_tracking``) and the
load (``iae_load``), ``"PID"``, ``"ADRC"`` or ``"tie"``: the best eligible
candidate of each family on the model (the PID family: PI, PID, PID + Smith;
the ADRC family: the orders 1..3 and the delayed-ESO ADRC), and a tie when
``|a - p| <= tie max(a, p)``.  ``verdict(summary)`` writes the sentences; each
lists the numbers it shows as paths into ``compare.json`` (``quotes``), so a
test can read every one back.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

__all__ = ["verdict", "winners"]

_SIMILAR_TV = 0.2  # MV travels within 20 % are "similar"
_WORDS = {
    "iae_tracking": ("tracks the set-point step", "the set-point step", "setpoint"),
    "iae_load": ("rejects the load", "the load rejection", "load"),
}


def _val(res: dict[str, Any], name: str, m: str, where: str = "model") -> float:
    v = res[name][where][m]
    return math.inf if v is None or not math.isfinite(v) else v


def _families(s: dict[str, Any]) -> dict[str, list[str]]:
    return {t: [c["name"] for c in s["controllers"] if c["eligible"] and c["type"] == t]
            for t in ("PID", "ADRC")}  # fmt: skip


def winners(s: dict[str, Any]) -> dict[str, Any]:
    """``{"setpoint": w, "load": w, "band": tie, "best": {...}}`` (module docstring)."""
    res, kinds, tie = s["metrics"], _families(s), s["tie"]
    out: dict[str, Any] = {"band": tie, "best": {}}
    for key, (_d, _w, case) in _WORDS.items():
        if not (kinds["PID"] and kinds["ADRC"]):
            out[case] = "PID" if kinds["PID"] else ("ADRC" if kinds["ADRC"] else None)
            continue
        a = min(kinds["ADRC"], key=lambda n: _val(res, n, key))
        p = min(kinds["PID"], key=lambda n: _val(res, n, key))
        va, vp = _val(res, a, key), _val(res, p, key)
        out["best"][case] = {"PID": p, "ADRC": a}
        if abs(va - vp) <= tie * max(va, vp):
            out[case] = "tie"
        else:
            out[case] = "ADRC" if va < vp else "PID"
    return out


def _q(path: Sequence[Any], value: float, scale: float = 1.0, fmt: str = ".4g") -> dict[str, Any]:
    return {"path": list(path), "scale": scale, "fmt": fmt, "shown": _num(value, scale, fmt)}


def _num(value: float, scale: float = 1.0, fmt: str = ".4g") -> str:
    if value is None or not math.isfinite(value):
        return "not finite"
    return format(scale * value, fmt)


def _less(a: float, b: float) -> float:
    """``100 (1 - a/b)``: how many per cent ``a`` is below ``b``."""
    return 100.0 * (1.0 - a / b) if b > 0 else 0.0


def verdict(s: dict[str, Any]) -> list[dict[str, Any]]:
    """Plain-words sentences; each lists the JSON paths of the numbers it quotes."""
    ctrls, res = s["controllers"], s["metrics"]
    said: list[dict[str, Any]] = [_conditions(s)]
    for i, c in enumerate(ctrls):
        if c["params"] is None:
            said.append({"text": f"{c['name']} is not designed: {c['error']}", "quotes": []})
        elif not c["eligible"]:
            mg = c["margins"]
            if mg["stable"]:
                q = [_q(["controllers", i, "margins", "ms"], mg["ms"], fmt=".3g")]
                text = (f"{c['name']} is left out: Ms = {q[0]['shown']} on the model, above the "
                        "target.")  # fmt: skip
            else:
                q, text = [], f"{c['name']} is left out: unstable on the model."
            said.append({"text": text, "quotes": q})
    ok = [c["name"] for c in ctrls if c["eligible"]]
    kinds = _families(s)
    if not ok:
        said.append({"text": "No candidate reaches the target on the model: no verdict.",
                     "quotes": []})  # fmt: skip
        return said
    for key, (does, _what, _case) in _WORDS.items():
        best = min(ok, key=lambda n: _val(res, n, key))
        q = [_q(["metrics", best, "model", key], _val(res, best, key))]
        text = f"{best} {does} best on the model (IAE {q[0]['shown']}"
        others = [n for n in ok if n != best]
        if others:
            nxt = min(others, key=lambda n: _val(res, n, key))
            q.append(_q(["metrics", nxt, "model", key], _val(res, nxt, key)))
            text += f"; {_less(_val(res, best, key), _val(res, nxt, key)):.0f} % less than {nxt}, "
            text += q[1]["shown"]
        said.append({"text": text + ").", "quotes": q})
        spread = res[best]["corners"].get(key)
        if spread:
            q = [_q(["metrics", best, "corners", key, j], spread[j]) for j in (0, 1)]
            said.append({"text": f"Over the uncertainty corners its IAE ranges "
                         f"{q[0]['shown']}..{q[1]['shown']}.", "quotes": q})  # fmt: skip
    for kind in ("PID", "ADRC"):
        if not kinds[kind]:
            said.append({"text": f"No {kind} candidate is in the verdict (see above).",
                         "quotes": []})  # fmt: skip
    if kinds["ADRC"] and kinds["PID"]:
        for key, tv in (("iae_tracking", "tv_u_tracking"), ("iae_load", "tv_u_load")):
            said.append(_kind_sentence(s, key, tv))
    contenders = [min(kinds[k], key=lambda n: _val(res, n, "iae_load")) for k in kinds if kinds[k]]
    said += _corner_overshoot(res, contenders, s["box"]["dead_time"])
    if s.get("monte_carlo"):
        said += _monte_carlo_sentences(s, res, contenders)
    said += _tradeoff_sentences(s)
    return said


def _conditions(s: dict[str, Any]) -> dict[str, Any]:
    """The robustness and noise level the verdict holds at, and the experiment."""
    q = [_q(["ms_target"], s["ms_target"], fmt=".3g"),
         _q(["noise_std"], s["noise_std"], fmt=".3g"),
         _q(["mv_noise_max"], s["mv_noise_max"], fmt=".3g"),
         _q(["t_event"], s["t_event"], fmt=".4g"),
         _q(["tie"], s["tie"], 100.0, ".3g")]  # fmt: skip
    rest = s.get("rest") or {}
    taus = rest.get("time_constants") or {}
    at_rest = ""
    if taus:
        slow = max(taus, key=lambda n: taus[n])
        q.append(_q(["rest", "time_constants", slow], taus[slow], fmt=".3g"))
        at_rest = (f" ({rest['times']:g} times the slowest closed-loop time constant, "
                   f"{q[-1]['shown']} s of {slow}: the release's transient has died out)")
    return {"text": f"Every candidate is designed to Ms <= {q[0]['shown']} on the model and to an "
            f"MV noise of at most {q[2]['shown']} (standard deviation) from the record's PV noise "
            f"of {q[1]['shown']}; each event comes {q[3]['shown']} s after the loop was released "
            f"to AUTO{at_rest}; results within {q[4]['shown']} % of each other are a tie.",
            "quotes": q}  # fmt: skip


def _kind_sentence(s: dict[str, Any], key: str, tv: str) -> dict[str, Any]:
    """Best ADRC against best PID on one experiment (the winners), with their MV travel."""
    res = s["metrics"]
    _does, what, case = _WORDS[key]
    best = s["winners"]["best"][case]
    a, p = best["ADRC"], best["PID"]
    va, vp, ta, tp = _val(res, a, key), _val(res, p, key), _val(res, a, tv), _val(res, p, tv)
    qa, qp = _q(["metrics", a, "model", key], va), _q(["metrics", p, "model", key], vp)
    qta, qtp = _q(["metrics", a, "model", tv], ta), _q(["metrics", p, "model", tv], tp)
    band = f"{100 * s['tie']:g} %"
    if s["winners"][case] == "tie":
        text = (f"PID and ADRC tie on {what} ({key}, within {band}): {a} IAE {qa['shown']}, {p} "
                f"{qp['shown']}")  # fmt: skip
        win_t, lose_t, win_q, lose_q = ta, tp, qta, qtp
    else:
        (w, vw, qw, win_t, win_q), (lo, vl, ql, lose_t, lose_q) = sorted(
            [(a, va, qa, ta, qta), (p, vp, qp, tp, qtp)], key=lambda x: x[1]
        )
        text = (f"{s['winners'][case]} wins {what} ({key}): {w} has {_less(vw, vl):.0f} % "
                f"less IAE than {lo} ({qw['shown']} against {ql['shown']}; tie band "
                f"{band})")  # fmt: skip
    first = "ADRC" if win_q is qta else "PID"
    if abs(win_t - lose_t) <= _SIMILAR_TV * max(win_t, lose_t):
        how = "at similar MV travel"
    elif win_t < lose_t:
        how = f"with {_less(win_t, lose_t):.0f} % less MV travel"
    elif win_t < 2.0 * lose_t:
        how = f"with {100.0 * (win_t / lose_t - 1.0):.0f} % more MV travel"
    elif lose_t > 0.0:
        how = f"with {win_t / lose_t:.2g} times the MV travel"
    else:  # the other controller did not move the MV at all in these windows
        how = "moving the MV where the other does not"
    text += f", {how} ({first} {win_q['shown']} against {lose_q['shown']})."
    return {"text": text, "quotes": [qa, qp, qta, qtp]}


def _corner_overshoot(res, contenders, dead_time: float) -> list[dict[str, Any]]:
    """The overshoot of the contenders under +30 % dead time (worst of those corners)."""
    out = []
    pct = round(100 * dead_time)
    for n in contenders:
        worst = res[n]["dead_time_plus"].get("overshoot")
        if worst is None:
            continue
        q = [
            _q(["metrics", n, "dead_time_plus", "overshoot"], worst, 100.0, ".3g"),
            _q(["metrics", n, "model", "overshoot"], _val(res, n, "overshoot"), 100.0, ".3g"),
        ]
        verb = "grows to" if worst > _val(res, n, "overshoot") else "stays at"
        out.append({"text": f"Under +{pct} % dead time (the worst of the corners with it) the "
                    f"set-point overshoot of {n} {verb} {q[0]['shown']} % ({q[1]['shown']} % on "
                    "the model).", "quotes": q})  # fmt: skip
    return out


def _monte_carlo_sentences(s, res, contenders) -> list[dict[str, Any]]:
    mc = s["monte_carlo"]
    out = []
    for key in ("iae_load", "iae_tracking"):
        _does, what, _case = _WORDS[key]
        parts, q = [], []
        for n in contenders:
            st = res[n]["monte_carlo"][key]
            qm = _q(["metrics", n, "monte_carlo", key, "median"], st["median"])
            qw = _q(["metrics", n, "monte_carlo", key, "worst"], st["worst"])
            q += [qm, qw]
            parts.append(f"{n} median {qm['shown']}, worst {qw['shown']}")
        out.append({"text": f"Over {mc['n']} models drawn from the uncertainty box (seed "
                    f"{mc['seed']}) the IAE of {what}: " + "; ".join(parts) + ".",
                    "quotes": q})  # fmt: skip
    return out


def _tradeoff_sentences(s: dict[str, Any]) -> list[dict[str, Any]]:
    """Load IAE of the best of each family at the lowest and highest robustness level."""
    tr = s.get("tradeoff") or {}
    out = []
    for fam in ("PID", "ADRC"):
        f = tr.get(fam)
        if not f:
            continue
        pts = [i for i, v in enumerate(f["iae_load"]) if v is not None and math.isfinite(v)]
        if len(pts) < 2:
            continue
        i, j = pts[0], pts[-1]
        q = [_q(["tradeoff", fam, "ms", i], f["ms"][i], fmt=".3g"),
             _q(["tradeoff", fam, "iae_load", i], f["iae_load"][i]),
             _q(["tradeoff", fam, "ms", j], f["ms"][j], fmt=".3g"),
             _q(["tradeoff", fam, "iae_load", j], f["iae_load"][j])]  # fmt: skip
        out.append({"text": f"Trade-off ({f['name']}, designed again at each level, linear loop on "
                    f"the model): load IAE {q[1]['shown']} at Ms {q[0]['shown']}, {q[3]['shown']} "
                    f"at Ms {q[2]['shown']} (tradeoff.png).", "quotes": q})  # fmt: skip
    return out
