"""One noise resolution (estimators.models.noise_in_force) and one χ² gate (estimators.models.chi2_gate), used by
every estimator that resolves noise or gates innovations."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from slamarena.datasets.sequence import Noise, Sequence
from slamarena.estimators.models import UNSTATED_TWIST_COV, chi2_gate, noise_in_force

ROOT = Path(__file__).resolve().parents[2]


def test_the_parameter_else_the_stated_noise_else_the_default():
    stated = Sequence(name="s", noise=Noise(twist_cov=np.diag([4.0, 9.0])))
    bare = Sequence(name="bare")
    param = [[1.0, 0.0], [0.0, 2.0]]
    np.testing.assert_array_equal(noise_in_force(param, stated, "twist_cov", UNSTATED_TWIST_COV), np.diag([1.0, 2.0]))
    np.testing.assert_array_equal(noise_in_force(None, stated, "twist_cov", UNSTATED_TWIST_COV), np.diag([4.0, 9.0]))
    np.testing.assert_array_equal(noise_in_force(None, bare, "twist_cov", UNSTATED_TWIST_COV), UNSTATED_TWIST_COV)
    assert noise_in_force(None, None, "twist_cov") is None  # no sequence (a filter reset without one)
    assert noise_in_force(None, bare, "increment_cov") is None
    with pytest.raises(ValueError, match="bare: no gps_cov stated; pass gps_cov="):
        noise_in_force(None, bare, "gps_cov", required=True)


@pytest.mark.parametrize("confidence", [0.5, 0.95, 0.99, 0.999, 0.99999])
@pytest.mark.parametrize("dof", [1, 2, 3, 4, 6])
def test_the_gate_is_the_chi2_quantile(confidence, dof):
    assert chi2_gate(confidence, dof) == float(chi2.ppf(confidence, dof))  # bit for bit: the spelling it replaces


def test_no_gate_for_confidence_one_or_none():
    assert chi2_gate(1.0, 2) == np.inf and chi2_gate(None, 3) == np.inf


def test_no_estimator_spells_the_gate_or_the_noise_resolution_itself():
    spelled = re.compile(r"chi2\.ppf|gammaincinv|getattr\(noise, \"|else sequence\.noise\.")
    offences = [
        f"{path.relative_to(ROOT)}:{k}: {line.strip()}"
        for path in sorted((ROOT / "estimators").rglob("*.py"))
        if path != ROOT / "estimators" / "models.py"
        for k, line in enumerate(path.read_text().splitlines(), 1)
        if spelled.search(line)
    ]
    assert not offences, "\n".join(offences)
