"""Tuning: from a bump test to PID and ADRC settings.

* :mod:`.identify` -- FOPDT/SOPDT/integrating models from step-response
  records (two-point methods, least squares);
* :mod:`.records` -- records from CSV files as historians and spreadsheets
  export them (time formats, local time, bad cells, gaps, a time window);
* :mod:`.halfrule` -- Skogestad's half rule and the inverse half-rule of
  Nowak et al. 2018 for the ADRC ``b0``;
* :mod:`.adrc` -- ADRC bandwidth tuning and a ready ``ctrlblocks.ADRC``
  configuration;
* :mod:`.pid_rules` -- SIMC, AMIGO, Ziegler-Nichols, Tyreus-Luyben and
  lambda tuning in ISA form;
* :mod:`.relay` -- relay-feedback auto-tuning and bump-test pre-tuning
  against a simulated plant.

The guide is docs/tuning.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover
    from .adrc import ADRCTuning, adrc_bandwidth, adrc_config, adrc_tuning
    from .halfrule import InverseHalfRule, half_rule, inverse_half_rule
    from .identify import (
        FOPDT,
        SOPDT,
        Integrating,
        fit_fopdt,
        fit_integrating,
        fit_sopdt,
        sundaresan_krishnaswamy,
        two_point,
    )
    from .pid_rules import (
        PIDTuning,
        amigo,
        lambda_tuning,
        pid_from_model,
        simc,
        tyreus_luyben,
        ziegler_nichols_closed,
        ziegler_nichols_open,
    )
    from .records import DataFileError, Record, StepData, read_record, read_step_csv
    from .relay import BumpTestResult, RelayResult, bump_test, relay_autotune, step_pretune

# imported on first use (PEP 562): ``ctrlblocks <command> --help`` imports none of them
_WHERE = {
    ".adrc": ("ADRCTuning", "adrc_bandwidth", "adrc_config", "adrc_tuning"),
    ".halfrule": ("InverseHalfRule", "half_rule", "inverse_half_rule"),
    ".identify": (
        "FOPDT",
        "SOPDT",
        "Integrating",
        "fit_fopdt",
        "fit_integrating",
        "fit_sopdt",
        "sundaresan_krishnaswamy",
        "two_point",
    ),
    ".records": ("DataFileError", "Record", "StepData", "read_record", "read_step_csv"),
    ".pid_rules": (
        "PIDTuning",
        "amigo",
        "lambda_tuning",
        "pid_from_model",
        "simc",
        "tyreus_luyben",
        "ziegler_nichols_closed",
        "ziegler_nichols_open",
    ),
    ".relay": ("BumpTestResult", "RelayResult", "bump_test", "relay_autotune", "step_pretune"),
}

__all__ = [
    "FOPDT",
    "SOPDT",
    "ADRCTuning",
    "BumpTestResult",
    "DataFileError",
    "Integrating",
    "InverseHalfRule",
    "PIDTuning",
    "Record",
    "RelayResult",
    "StepData",
    "adrc_bandwidth",
    "adrc_config",
    "adrc_tuning",
    "amigo",
    "bump_test",
    "fit_fopdt",
    "fit_integrating",
    "fit_sopdt",
    "half_rule",
    "inverse_half_rule",
    "lambda_tuning",
    "pid_from_model",
    "read_record",
    "read_step_csv",
    "relay_autotune",
    "simc",
    "step_pretune",
    "sundaresan_krishnaswamy",
    "two_point",
    "tyreus_luyben",
    "ziegler_nichols_closed",
    "ziegler_nichols_open",
]

__getattr__, __dir__ = lazy_exports(__name__, _WHERE)
