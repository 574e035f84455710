"""Tuning from a simulated bump test, with margins: the ``[controllers.tune]`` of scenarios.

:func:`tune_from_bump_test` is the whole workflow a scenario asks for when it
is loaded: step the plant by ``du`` from the operating point
(:func:`~ctrlblocks.tuning.relay.bump_test`), fit an FOPDT
(:func:`~ctrlblocks.tuning.identify.fit_fopdt`), apply the rule (a PID rule
of :func:`~ctrlblocks.tuning.pid_rules.pid_from_model` or the ADRC tuning of
:func:`~ctrlblocks.tuning.adrc.adrc_tuning`) and compute the margins of the
block as configured (the scenario table's parameters with the tuned ones) on
the fitted model (:mod:`ctrlblocks.tuning.margins`).

The ADRC without a settling time and the PID rule ``migo`` are designed as
``ctrlblocks compare`` designs them (:mod:`ctrlblocks.tuning.design`: the
smallest load IAE with ``Ms <= ms``, default 1.6, and the MV noise from the
record's PV noise within 5 % of the bump) on the FOPDT or SOPDT fit with the
smaller BIC (:func:`ctrlblocks.tuning.select.select_model`), and their margins
are those on that model.  With a settling time the paper's rule is applied as
written: inverse half-rule b0 and bandwidths on the FOPDT; the other PID rules
work on the FOPDT fit.
The scenario parser checks the table's keys and calls this function; every
tuning failure is a ``ValueError``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..blocks.base import ErrorCode, ParameterError

__all__ = ["PID_RULES", "better_model", "fopdt_of", "tune_from_bump_test"]

PID_RULES = ("migo", "amigo", "simc", "zn", "lambda")
"""The PID rules of ``[controllers.tune]`` (``rule = "adrc"`` for an ADRC); ``migo`` is
the design of ``ctrlblocks compare``."""


def better_model(t: Any, u: Any, y: Any, fopdt: Any = None) -> tuple[Any, Any, Any, str]:
    """``(fopdt, sopdt or None, the model used, why)`` of a bump test ``(t, u, y)``:
    the fit with the smaller BIC (:func:`ctrlblocks.tuning.select.select_model`)."""
    from .select import select_model

    c = select_model(t, u, y, fopdt)
    return c.fopdt, c.sopdt, c.model, c.why


def fopdt_of(model: Any) -> tuple[float, float, float]:
    """``(k, T, L)``: an FOPDT's own, or the half rule of an SOPDT (Skogestad 2003)."""
    from .identify import SOPDT

    if isinstance(model, SOPDT):
        t2 = model.time_constant_2
        return model.gain, model.time_constant + t2 / 2, model.dead_time + t2 / 2
    return model.gain, model.time_constant, model.dead_time


def tuned_model(info: Mapping[str, Any]) -> tuple[Any, str]:
    """``(model, description)`` a ``[controllers.tune]`` result was tuned and analysed on."""
    from .identify import FOPDT, SOPDT

    m = info.get("model") or {"model": "fopdt"}
    if m["model"] == "sopdt":
        return (
            SOPDT(m["gain"], m["time_constant"], m["dead_time"], m["time_constant_2"]),
            f"SOPDT fit k = {m['gain']:.4g}, T1 = {m['time_constant']:.4g} s, "
            f"T2 = {m['time_constant_2']:.4g} s, T0 = {m['dead_time']:.4g} s",
        )
    return (
        FOPDT(info["gain"], info["time_constant"], info["dead_time"]),
        f"FOPDT fit k = {info['gain']:.4g}, T = {info['time_constant']:.4g} s, "
        f"T0 = {info['dead_time']:.4g} s",
    )


def tune_from_bump_test(
    plant: Any,
    block_type: str,
    rule: str,
    du: float,
    *,
    ts: float,
    u0: float = 0.0,
    duration: float | None = None,
    controller: str = "pid",
    order: int = 2,
    settling_time: float | None = None,
    ms: float | None = None,
    block_params: Mapping[str, Any] | None = None,
    record: tuple[Any, Any, Any] | None = None,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Bump test, FOPDT fit, rule and margins; returns ``(tuned, info)``.

    Parameters
    ----------
    plant : Plant
        The process (without actuator and sensor), stepped by ``du`` from ``u0``.
    block_type : {"PID", "ADRC"}
    rule : str
        One of :data:`PID_RULES` for a PID, ``"adrc"`` for an ADRC.
    du : float
        Size of the bump [MV unit], non-zero.
    ts : float
        The controller's sample time [s].
    u0, duration
        Operating point [MV unit] and record length [s] (see ``bump_test``).
    controller : {"pi", "pid"}
        PID rules only.
    order, settling_time, ms
        ADRC only: order 1..3, the rule's settling time [s] (None: the safe
        default) and the Ms target of the default (None: 1.6).
    block_params : mapping, optional
        The other parameters of the block table (``n``, ``b``, ``u_min``, ...):
        the margins are those of the block built from them and the tuned ones.
    record : (t, u, y), optional
        A recorded bump test (e.g. :func:`~ctrlblocks.tuning.identify.read_step_csv`
        of the plant's real data) fitted instead of a simulated one; ``plant``,
        ``du``, ``u0`` and ``duration`` are then not used.

    Returns
    -------
    tuned : dict
        The block parameters found (they replace those of the table).
    info : dict
        ``rule, du, u0, gain, time_constant, dead_time`` (the FOPDT fit),
        ``model`` (``as_dict()`` of the model tuned on: the FOPDT, or for the
        ADRC's safe default possibly the SOPDT) and ``why``, ``parameters``
        and ``margins`` (``ms, gm, pm, wc_crossover, stable`` on that model,
        or None when the block's configuration has no linear margins, e.g. a
        PID with a PV filter) and ``warnings``.
    """
    import numpy as np

    from .adrc import MS_DEFAULT, adrc_tuning
    from .design import MV_NOISE_FRACTION, design_adrc, design_pid
    from .identify import fit_fopdt
    from .pid_rules import pid_from_model
    from .relay import bump_test

    if record is None:
        if du == 0.0:
            raise ParameterError(ErrorCode.BAD_PARAMETER, "du", "must be non-zero")
        t, u, y = bump_test(plant, du, u0=u0, duration=duration)
    else:
        t, u, y = record
    model = fit_fopdt(t, u, y)
    tuned_on, why = model, "FOPDT"
    designed = rule == "migo" or (block_type == "ADRC" and settling_time is None)
    if designed:
        _fo, _so, tuned_on, why = better_model(t, u, y, model)
    t_arr, u_arr, y_arr = (np.asarray(v, float) for v in (t, u, y))
    noise = float(np.std(y_arr - tuned_on.response(t_arr, u_arr)))
    budget = MV_NOISE_FRACTION * abs(float(u_arr[-1] - u_arr[0]) or 1.0)
    target = MS_DEFAULT if ms is None else ms
    info: dict[str, Any] = {
        "rule": rule,
        "du": du if record is None else float(u[-1] - u[0]),
        "u0": u0 if record is None else float(u[0]),
        "gain": model.gain,
        "time_constant": model.time_constant,
        "dead_time": model.dead_time,
        "model": tuned_on.as_dict(),
        "why": why,
    }
    params = dict(block_params or {})
    warnings: list[str] = []
    if block_type == "ADRC":
        if rule != "adrc":
            raise ParameterError(ErrorCode.BAD_PARAMETER, "rule", "an ADRC is tuned by 'adrc'")
        disc = str(params.get("discretisation", "euler"))
        if settling_time is None:
            d = design_adrc(tuned_on, order, ts, ms=target, noise_std=noise,
                            mv_noise_max=budget, discretisation=disc)  # fmt: skip
            tuned: dict[str, Any] = dict(d.params)
            warnings += d.warnings
        else:
            res = adrc_tuning(
                *fopdt_of(tuned_on), order, settling_time=settling_time, ts=ts, ms=target,
                discretisation=disc, model=tuned_on,
            )  # fmt: skip
            tuned = res.settings()  # reverse = True for a negative gain
            warnings += res.warnings
    elif rule == "migo":
        dp = design_pid(tuned_on, ts, ms=target, noise_std=noise, mv_noise_max=budget,
                        controller=controller)  # fmt: skip
        tuned = dict(dp.params)
        warnings += dp.warnings
    else:
        res_pid = pid_from_model(model, rule, controller=controller)
        tuned = {"kp": abs(res_pid.kp), "ti": res_pid.ti, "td": res_pid.td}
        if res_pid.kp < 0:
            tuned["reverse"] = True
        if res_pid.b is not None:
            tuned["b"] = res_pid.b
    info["parameters"] = dict(tuned)
    info["margins"] = block_margins(tuned_on, block_type, {**params, **tuned}, ts)
    mg = info["margins"]
    if mg is not None and (not mg["stable"] or mg["ms"] > 2.0):
        warnings.append(
            f"the {rule} tuning is {'unstable' if not mg['stable'] else 'fragile (Ms > 2)'} "
            f"on the {info['model']['model'].upper()} fit of the bump test"
        )
    info["warnings"] = warnings
    return tuned, info


def block_margins(
    model: Any, block_type: str, params: Mapping[str, Any], ts: float
) -> dict[str, Any] | None:
    """``Margins.as_dict()`` of the block ``block_type(**params, ts=ts)`` on ``model``.

    None when the block cannot be analysed (not a PID/ADRC, or a configuration
    without a linear law, e.g. a PID with a setpoint ramp or a dead band, or
    refused parameters, which the caller reports itself).  ``"warnings"``: the
    notes of :attr:`Margins.warnings`, when there are any.
    """
    from ..blocks.registry import BLOCK_TYPES, is_controller_type
    from .margins import margins

    if not is_controller_type(block_type):
        return None
    cls = BLOCK_TYPES[block_type]
    try:
        block = cls(**{**params, "ts": ts})
        mg = margins(model, block)
    except (ParameterError, TypeError):
        return None
    out: dict[str, Any] = dict(mg.as_dict())
    if mg.warnings:
        out["warnings"] = list(mg.warnings)
    return out
