"""Cascade control: the primary's output is the secondary's setpoint.

The structure ``cascade`` (Åström 1987, section 3, "Cascade Control"): the
primary controller on ``y`` computes the setpoint of the secondary on the
inner variable ``y2``, whose output is the MV.  The secondary's anti-windup
output ``awout`` goes to the primary's ``awin`` (the AW handshake of Nowak
et al. 2018, section 5; ``aw_handshake = false`` turns it off): while the
secondary is at a limit the primary's integral action is frozen.  While the
inner loop is open the primary tracks (:meth:`.Wiring.follow`): ``y2`` while
the secondary is not in AUTO, its own last output while ``y2`` is bad.
"""

from __future__ import annotations

from .structure import ENTRY_KEYS, Structure
from .wiring import Loop, Measured, Wiring

__all__ = ["Cascade"]


def _wiring(handshake: bool) -> Wiring:
    primary = Loop(
        "primary", awin="secondary" if handshake else None, follows="secondary", signal="sp2"
    )
    return Wiring((primary, Loop("secondary", sp="primary", pv="y2", ok=("y2",))), mv="secondary")


_WIRINGS = {hs: _wiring(hs) for hs in (True, False)}


class Cascade(Structure):
    """The primary's output is the secondary's setpoint; the AW handshake between them."""

    name = "cascade"
    roles = ("primary", "secondary")
    options = ("aw_handshake",)
    measurements = ("y", "y2")
    mv_roles = ("secondary",)
    event_target = "primary"
    series_plant = True
    tuned_roles = ()
    wiring = _WIRINGS[True]

    def parse(self, r, e, key, ts, tune):
        r.check_keys(e, {*ENTRY_KEYS, *self.roles, *self.options}, key)
        hs = e.get("aw_handshake", True)
        if not isinstance(hs, bool):
            raise r.fail(f"{key}.aw_handshake", f"must be true or false, got {hs!r}")
        return {role: r.role(e, role, key, ts) for role in self.roles}, {"aw_handshake": hs}

    def wiring_of(self, side):
        return _WIRINGS[bool(side.spec.options.get("aw_handshake", True))]

    def follow_value(self, side, m: Measured) -> float | None:
        """What the primary tracks in this sample, or None: it runs in its own mode
        (:meth:`.Wiring.follow`)."""
        follow = self.follow(side, m)
        return None if follow is None else follow[1]

    def follow(self, side, m: Measured) -> tuple[str, float] | None:
        """:meth:`follow_value` with what it is: ``("y2", y2)``, ``("hold", last output)``."""
        return side.wiring.follow(side, side.wiring.loops[0], m)
