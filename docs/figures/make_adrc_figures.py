"""Make the figures of docs/blocks/adrc.md.

Run from the repository root::

    .venv/bin/python docs/figures/make_adrc_figures.py

All runs use the process (10b) of Nowak et al. 2018, ``0.73/((7.3s+1)(2.2s+1)(1.4s+1))``
(:class:`ctrlblocks.plants.PTn`, exact ZOH), ts = 0.1 s, and the Table 2
tunings.  Writes

* ``adrc_fig6.png``: the functional test of Nowak et al. 2018, Fig. 6 (n = 3): MAN with
  u_man = 1 until t = 40 s, switch to AUTO in the transient (sp = 1.5); sp = 4
  (out of reach: u at 5) from 100 s to 200 s; load +1 on u at 260 s; sp = 0.3
  (out of reach with the load: u at 0) from 320 s to 400 s;
* ``adrc_orders.png``: Nowak et al. 2018, Fig. 5 conditions for n = 1, 2, 3 (setpoint
  step at 10 s, load -0.5 on u at 150 s);
* ``adrc_antiwindup.png``: the lock of the literal x4 freeze (section 4.1) and
  the directional rule: steady at sp = 2, u_max lowered to 2 at 100 s, load +1
  at 200 s (n = 2);
* ``adrc_antibackoff.png``: Nowak et al. 2018, Fig. 1 conditions: n = 3, b0 = 0.023,
  sensor saturation 1.9, load +1.5 at 10 s, without and with (12a)/(12b).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from ctrlblocks import ADRC
from ctrlblocks.plants import PTn

HERE = Path(__file__).resolve().parent
TS = 0.1
TABLE2 = {1: (0.3, 0.9, 0.3), 2: (0.05, 1.75, 0.35), 3: (0.025, 1.75, 0.35)}


def plant_10b(u0: float = 0.0) -> PTn:
    p = PTn(k=0.73, t=[7.3, 2.2, 1.4], ts=TS)
    p.reset(u0)
    return p


def adrc(n: int, **kw: object) -> ADRC:
    b0, wo, wc = TABLE2[n]
    params = {"order": n, "b0": b0, "omega_o": wo, "omega_c": wc, "ts": TS}
    params.update(kw)
    return ADRC(**params)


def fig6() -> None:
    block = adrc(3, u_min=0.0, u_max=5.0)
    plant = plant_10b()
    t, ys, sps, us = [], [], [], []

    def setpoint(tk: float) -> float:
        return 4.0 if 100 <= tk < 200 else 0.3 if 320 <= tk < 400 else 1.5

    for k in range(round(480 / TS)):
        tk = k * TS
        block.manual = tk < 40.0
        block.u_man = 1.0
        sp = setpoint(tk)
        load = 1.0 if tk >= 260 else 0.0
        u = block(sp, plant.y)
        t.append(tk)
        ys.append(plant.y)
        sps.append(sp)
        us.append(u)
        plant.step(u + load)
    fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.5))
    a1.plot(t, sps, "k--", lw=1, label="setpoint")
    a1.plot(t, ys, lw=1.5, label="Y")
    for tv, text in ((40, "MAN -> AUTO"), (260, "load +1")):
        a1.axvline(tv, color="grey", lw=0.8)
        a1.text(tv + 2, 3.6, text, fontsize=8)
    a1.set_ylabel("Y")
    a1.legend(loc="center right", fontsize=8)
    a2.plot(t, us, lw=1.5, color="C3", label="u")
    a2.axhline(0, color="k", lw=0.6, ls=":")
    a2.axhline(5, color="k", lw=0.6, ls=":")
    a2.set_ylabel("u (limits 0..5)")
    a2.set_xlabel("t [s]")
    fig.suptitle("ADRC n = 3 on (10b), Table 2 tuning: functional test (Nowak et al. 2018, Fig. 6)")
    fig.tight_layout()
    fig.savefig(HERE / "adrc_fig6.png", dpi=110)
    plt.close(fig)


def orders() -> None:
    fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.5))
    for n in (1, 2, 3):
        block = adrc(n, u_min=0.0, u_max=5.0)
        plant = plant_10b()
        t, ys, us = [], [], []
        for k in range(round(250 / TS)):
            tk = k * TS
            u = block(2.0 if tk >= 10 else 0.0, plant.y)
            t.append(tk)
            ys.append(plant.y)
            us.append(u)
            plant.step(u - (0.5 if tk >= 150 else 0.0))
        a1.plot(t, ys, lw=1.3, label=f"n = {n}")
        a2.plot(t, us, lw=1.3, label=f"n = {n}")
    a1.set_ylabel("Y")
    a1.legend(fontsize=8)
    a2.set_ylabel("u")
    a2.set_xlabel("t [s]")
    fig.suptitle("Orders 1..3 with the Table 2 tunings on (10b) (cf. Nowak et al. 2018, Fig. 5)")
    fig.tight_layout()
    fig.savefig(HERE / "adrc_orders.png", dpi=110)
    plt.close(fig)


def antiwindup() -> None:
    fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.5))
    u_ss = 2.0 / 0.73
    for rule, style in (("freeze", "C3"), ("directional", "C0")):
        block = adrc(2, u_min=0.0, u_max=5.0, u0=u_ss, anti_windup=rule)
        plant = plant_10b(u_ss)
        t, ys, us = [], [], []
        for k in range(round(500 / TS)):
            tk = k * TS
            if k == 1000:
                block.set_limits(0.0, 2.0)
            u = block(2.0, plant.y)
            t.append(tk)
            ys.append(plant.y)
            us.append(u)
            plant.step(u + (1.0 if k >= 2000 else 0.0))
        a1.plot(t, ys, color=style, lw=1.4, label=f'anti_windup="{rule}"')
        a2.plot(t, us, color=style, lw=1.4)
    a1.axhline(2.0, color="k", ls="--", lw=0.8)
    a1.set_ylabel("Y (sp = 2)")
    a1.legend(fontsize=8)
    a2.set_ylabel("u")
    a2.set_xlabel("t [s]  (u_max -> 2 at 100 s, load +1 at 200 s)")
    fig.suptitle("x4 freeze at a limit: the literal rule locks, the directional rule does not")
    fig.tight_layout()
    fig.savefig(HERE / "adrc_antiwindup.png", dpi=110)
    plt.close(fig)


def antibackoff() -> None:
    fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(8, 5.5))
    u_ss = 1.8 / 0.73
    for ab, style in ((False, "-"), (True, "--")):
        block = ADRC(
            order=3,
            b0=0.023,
            omega_o=1.75,
            omega_c=0.35,
            ts=TS,
            u_min=0.0,
            u_max=5.0,
            u0=u_ss,
            anti_backoff=ab,
            y_sat=1.9,
        )
        plant = plant_10b(u_ss)
        t, ys, us = [], [], []
        for k in range(round(70 / TS)):
            u = block(1.8, min(plant.y, 1.9))
            t.append(k * TS)
            ys.append(plant.y)
            us.append(u)
            plant.step(u + (1.5 if k >= 100 else 0.0))
        label = "with anti-backoff (12a)/(12b)" if ab else "without"
        a1.plot(t, ys, "k" + style, lw=1.3, label=label)
        a2.plot(t, us, "k" + style, lw=1.3)
    a1.axhline(1.9, color="grey", ls=":", lw=1)
    a1.set_ylabel("Y (true); sensor saturates at 1.9")
    a1.legend(fontsize=8)
    a2.set_ylabel("u")
    a2.set_xlabel("t [s]")
    fig.suptitle("Derivative backoff and the anti-backoff action (cf. Nowak et al. 2018, Fig. 1)")
    fig.tight_layout()
    fig.savefig(HERE / "adrc_antibackoff.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    fig6()
    orders()
    antiwindup()
    antibackoff()
