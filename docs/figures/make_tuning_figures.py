"""Make the bump-test example and the figure of docs/tuning.md.

Run from the repository root::

    .venv/bin/python docs/figures/make_tuning_figures.py

Writes
* docs/examples/bump_k2.csv (and the same file as tests/tuning/data/bump_k2.csv):
  a simulated bump test on process (10b) of Nowak et al. 2018,
  0.73/((7.3 s + 1)(2.2 s + 1)(1.4 s + 1)), sampled every 0.5 s, at the
  operating point MV = 2.0 bar, PV = 1.46 bar, MV step +0.5 bar at t = 10 s,
  Gaussian PV noise of standard deviation 0.002 bar (0.5 % of the PV change),
  seed 4;
* docs/figures/tuning_identify.png: the record against the least-squares FOPDT
  and SOPDT models;
* docs/examples/bump_dst.csv: a bump test recorded as WinCC writes it, in local
  time (Europe/Berlin) across the spring daylight-saving jump: the FOPDT
  2 e^{-9 s}/(20 s + 1), MV 50 -> 60 % at 90 s, samples every 0.5 s, no noise,
  stamps dd.mm.yyyy hh:mm:ss,fff from 2024-03-31 01:58 CET;
* docs/figures/tuning_deadtime_adrc.png and tuning_deadtime_pid.png: the worked
  dead-time example of docs/tuning.md (k = 2, T = 30 s, L = 5 s), the default
  ADRC n = 2 and the AMIGO PID with their margins, as ``tune ... --plot`` draws
  them; the numbers of the example are printed.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ctrlblocks.plants.linear import PTn
from ctrlblocks.tuning import fit_fopdt, fit_sopdt

ROOT = Path(__file__).resolve().parents[2]


def simulate() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ts, u0, du, t_step, t_end = 0.5, 2.0, 0.5, 10.0, 80.0
    plant = PTn(0.73, (7.3, 2.2, 1.4), ts)
    plant.reset(u0)
    rng = np.random.default_rng(4)
    n = round(t_end / ts) + 1
    t = np.arange(n) * ts
    u = np.where(t >= t_step, u0 + du, u0)
    y = np.empty(n)
    for k in range(n):
        y[k] = plant.y
        plant.step(u[k])
    y += rng.normal(0.0, 0.002, n)
    return t, u, y


def write_csv(path: Path, t, u, y) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time_s", "p_supply_bar", "p3_bar"])
        for row in zip(t, u, y, strict=True):
            w.writerow([f"{row[0]:.1f}", f"{row[1]:.3f}", f"{row[2]:.5f}"])


def write_dst_example(path: Path) -> None:
    """docs/examples/bump_dst.csv (the module docstring): the case of docs/tuning.md."""
    import datetime
    import zoneinfo

    berlin = zoneinfo.ZoneInfo("Europe/Berlin")
    start = datetime.datetime(2024, 3, 31, 0, 58, tzinfo=datetime.timezone.utc)
    t = np.arange(600) * 0.5
    u = np.where(t >= 90.0, 60.0, 50.0)
    s = t - 90.0 - 9.0
    y = 40.0 + np.where(s > 0.0, 20.0 * -np.expm1(-np.maximum(s, 0.0) / 20.0), 0.0)
    lines = ["Zeit;MV [%];PV [degC]"]
    for ti, ui, yi in zip(t, u, y, strict=True):
        d = (start + datetime.timedelta(seconds=float(ti))).astimezone(berlin)
        stamp = d.strftime("%d.%m.%Y %H:%M:%S,") + f"{d.microsecond // 1000:03d}"
        lines.append(f"{stamp};{ui:.4f};{yi:.6f}".replace(".", ",").replace(",", ".", 2))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def figure(t, u, y, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fo, so = fit_fopdt(t, u, y), fit_sopdt(t, u, y)
    fig, (ax, ax_u) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 5.0), height_ratios=(3, 1.3))
    ax.plot(t, y, ".", ms=3, color="0.5", label="bump test (10b) + noise")
    ax.plot(
        t,
        fo.response(t, u),
        color="C3",
        label=f"FOPDT k={fo.gain:.3f}, T={fo.time_constant:.2f} s, L={fo.dead_time:.2f} s",
    )
    ax.plot(
        t,
        so.response(t, u),
        "--",
        color="C2",
        label=f"SOPDT T1={so.time_constant:.2f} s, T2={so.time_constant_2:.2f} s, "
        f"L={so.dead_time:.2f} s",
    )
    ax.set_ylabel("p3 [bar]")
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3)
    ax.set_title("ctrlblocks identify: least-squares fits to a bump test", fontsize=10)
    ax_u.step(t, u, where="post")
    ax_u.set_ylabel("p_s [bar]")
    ax_u.set_xlabel("time [s]")
    ax_u.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def deadtime_example() -> None:
    """The worked example of docs/tuning.md: margins and plots on k = 2, T = 30 s, L = 5 s."""
    import math

    from ctrlblocks import ADRC, PID
    from ctrlblocks.tuning import FOPDT, adrc_tuning, amigo, simc
    from ctrlblocks.tuning.margins import Loop
    from ctrlblocks.tuning.plot import plot_loop

    model = FOPDT(2.0, 30.0, 5.0)
    old = Loop(model, ADRC(order=2, b0=0.008, omega_c=0.0952, omega_o=0.476, ts=0.2))
    print("old default ADRC n=2:", old.margins().summary())
    for n in (1, 2, 3):
        r = adrc_tuning(2.0, 30.0, 5.0, n)
        print(f"ADRC n={n}: omega_c {r.omega_c:.4g} omega_o {r.omega_o:.4g} ts {r.ts:g} "
              f"settling {r.settling_time_loop:.4g} s; {r.margins.summary()}")  # fmt: skip
        if n == 2:
            lp = Loop(model, ADRC(**r.config()))
            plot_loop(
                lp,
                r.margins,
                ROOT / "docs/figures/tuning_deadtime_adrc.png",
                title=f"Default ADRC n = 2 on 2 e^(-5s)/(30s + 1): omega_c = "
                f"{r.omega_c:.4g} rad/s, omega_o = {r.omega_o:.4g} rad/s, ts = {r.ts:g} s",
            )
    for tun in (amigo(2.0, 30.0, 5.0), simc(2.0, 30.0, 5.0)):
        lp = Loop(model, PID(**tun.as_kwargs(), ts=0.5, u_min=-math.inf, u_max=math.inf))
        mg = lp.margins()
        print(f"PID {tun.rule}: kp {tun.kp:.4g} ti {tun.ti:.4g} td {tun.td:.4g}; settling "
              f"{lp.settling_time():.4g} s; {mg.summary()}")  # fmt: skip
        if tun.rule == "amigo":
            plot_loop(
                lp,
                mg,
                ROOT / "docs/figures/tuning_deadtime_pid.png",
                title=f"AMIGO PID on 2 e^(-5s)/(30s + 1): kp = {tun.kp:.4g}, "
                f"ti = {tun.ti:.4g} s, td = {tun.td:.4g} s, b = 0, ts = 0.5 s",
            )


def main() -> None:
    deadtime_example()
    t, u, y = simulate()
    for p in (ROOT / "docs/examples/bump_k2.csv", ROOT / "tests/tuning/data/bump_k2.csv"):
        write_csv(p, t, u, y)
    figure(t, u, y, ROOT / "docs/figures/tuning_identify.png")
    write_dst_example(ROOT / "docs/examples/bump_dst.csv")


if __name__ == "__main__":
    main()
