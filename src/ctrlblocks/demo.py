"""``ctrlblocks demo``: a first look at the blocks, until ``reproduce`` exists."""

from __future__ import annotations

import click

from .blocks import PT1, MovingAverage, RateLimiter


@click.command()
@click.option("--steps", default=20, show_default=True, help="Samples to run.")
def demo(steps: int) -> None:
    """Push a unit step through a PT1 filter, a rate limiter and a moving average."""
    ts = 0.5
    blocks = {
        "PT1 t=2s": PT1(t=2.0, ts=ts),
        "ramp 0.25/s": RateLimiter(rate_up=0.25, rate_down=0.25, ts=ts),
        "mean of 4": MovingAverage(n=4),
    }
    click.echo(f"{'t [s]':>6} " + " ".join(f"{name:>12}" for name in blocks))
    for k in range(steps):
        outs = [block(1.0) for block in blocks.values()]
        click.echo(f"{(k + 1) * ts:6.1f} " + " ".join(f"{y:12.4f}" for y in outs))
