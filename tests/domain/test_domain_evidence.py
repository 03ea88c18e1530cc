import json

import numpy as np
import pytest
from hypothesis import given, settings

from strategies import structures
from unseeable.domain import (
    Evidence,
    Extent,
    Log,
    Structure,
    feature_values,
    load_evidence,
    save_evidence,
    simulate_evidence,
)
from unseeable.errors import InputError


@settings(max_examples=30, deadline=None)
@given(structures(max_positions=27))
def test_evidence_round_trip_and_log_probability(tmp_path_factory, structure):
    ev = simulate_evidence(structure, accuracy=0.8, occluded_fraction=0.3, seed=5)
    path = tmp_path_factory.mktemp("ev") / "e.json"
    save_evidence(ev, path)
    again = load_evidence(path)
    assert np.allclose(again.p, ev.p)
    g = feature_values(structure.extent, structure.occupancy)
    expected = np.sum(np.where(g, np.log(ev.p), np.log(1 - ev.p)))
    assert ev.log_probability(structure) == pytest.approx(expected)


def test_simulated_evidence_is_deterministic_and_respects_rates():
    s = Structure(Extent(4, 2, 4), [Log(0, (0, k), 3) for k in range(4)])
    a = simulate_evidence(s, accuracy=0.85, occluded_fraction=0.4, seed=3)
    b = simulate_evidence(s, accuracy=0.85, occluded_fraction=0.4, seed=3)
    assert np.array_equal(a.p, b.p)
    judged = a.judged
    assert 0.5 < judged.mean() < 0.7
    g = feature_values(s.extent, s.occupancy)
    right = ((a.p > 0.5) == g)[judged].mean()
    assert 0.78 < right < 0.92


def _write(tmp_path, data):
    p = tmp_path / "ev.json"
    p.write_text(json.dumps(data))
    return p


@pytest.mark.parametrize("feature, field, needle", [
    ({"kind": "u", "at": [0, 0, 0], "p": 1.5}, "features[0].p", "(0, 1)"),
    ({"kind": "u", "at": [0, 0, 0], "p": 0.0}, "features[0].p", "(0, 1)"),
    ({"kind": "x", "at": [0, 0, 0], "p": 0.7}, "features[0].kind", "unknown feature kind"),
    ({"kind": "end-", "at": [0, 2, 0], "p": 0.7}, "features[0].at", "no end- feature"),
    ({"kind": "u", "at": [0, 0], "p": 0.7}, "features[0].at", "[i, j, k]"),
])
def test_bad_evidence_files(tmp_path, feature, field, needle):
    path = _write(tmp_path, {"format": "unseeable/evidence@1", "extent": [2, 2, 2],
                             "features": [feature]})
    with pytest.raises(InputError) as err:
        load_evidence(path)
    msg = str(err.value)
    assert str(path) in msg and field in msg and needle in msg


def test_wrong_format_tag(tmp_path):
    path = _write(tmp_path, {"format": "unseeable/structure@1", "extent": [2, 2, 2]})
    with pytest.raises(InputError, match="format"):
        load_evidence(path)


def test_priors_out_of_range_rejected():
    with pytest.raises(InputError):
        Evidence(Extent(1, 1, 1), np.full(11, 1.0))
