"""WhiskerDesign: thesis defaults, derived radii and refusal of impossible designs."""

import math

import pytest

from geometry.design import InvalidDesignError, WhiskerDesign


def test_defaults_are_the_thesis_values():
    d = WhiskerDesign()
    assert (d.D, d.L, d.alpha, d.c, d.l, d.t, d.x_ss, d.e, d.trim) == (18, 70, 2.862, 2, 15, 3, 6, 2, 0)
    assert (d.fibre_pitch, d.fibre_diameter, d.n_fibres, d.fibre_E, d.fibre_nu) == (3.0, 0.38, 2, 31067.0, 0.36)
    assert d.fibre_radius_frac == 0.5
    d.validate()


def test_spec_radii():
    # the thesis design: outer diameter 17.8 at x=c, 16.5 at x=l; cavity 11.8 and 10.5; tip diameter 11
    d = WhiskerDesign()
    assert 2 * d.r_outer(d.c) == pytest.approx(17.8, abs=1e-3)
    assert 2 * d.r_outer(d.l) == pytest.approx(16.5, abs=2e-3)
    assert 2 * d.r_inner(d.c) == pytest.approx(11.8, abs=1e-3)
    assert 2 * d.r_inner(d.l) == pytest.approx(10.5, abs=2e-3)
    assert 2 * d.r_outer(d.L) == pytest.approx(11.0, abs=2e-3)
    assert d.r_fibre(d.c) == pytest.approx(d.r_inner(d.c) + 1.5)


def test_trimmed_is_same_design_shorter():
    d = WhiskerDesign().trimmed(10.0)
    assert d.length == 60.0 and d.L == 70.0 and d.trim == 10.0
    assert d.replace(trim=0.0) == WhiskerDesign()
    assert d.key() != WhiskerDesign().key()
    assert WhiskerDesign().key() == WhiskerDesign().key()


@pytest.mark.parametrize(
    "kw, names, fragment",
    [
        (dict(t=8.5), {"t", "l", "alpha", "D"}, "cavity radius"),
        (dict(alpha=8.0), {"alpha", "L"}, "tip radius"),
        (dict(l=2.0), {"c", "l"}, "c < l"),
        (dict(trim=52.0), {"trim", "l"}, "L - trim - l >= tip_clearance"),
        (dict(x_ss=14.0), {"x_ss", "e"}, "gauge inside the chamber"),
        (dict(x_ss=1.0), {"x_ss", "c"}, "gauge inside the chamber"),
        (dict(t=-1.0), {"t"}, "t > 0"),
        (dict(D=0.0), {"D"}, "D > 0"),
        (dict(fibre_radius_frac=1.5), {"fibre_radius_frac"}, "fibre_radius_frac"),
        (dict(trim=-1.0), {"trim"}, "trim >= 0"),
        (dict(t=0.3), {"fibre_diameter", "t"}, "fibre fits"),
    ],
)
def test_invalid_designs_are_refused_with_a_one_line_message(kw, names, fragment):
    d = WhiskerDesign(**kw)
    with pytest.raises(InvalidDesignError) as ei:
        d.validate()
    err = ei.value
    assert isinstance(err, ValueError)
    msg = str(err)
    assert "\n" not in msg
    assert fragment in msg
    assert names <= set(err.parameters)
    for k, v in kw.items():
        assert f"{k}={v:g}" in msg  # names the parameter and its value
    assert not d.is_valid


def test_message_lists_every_violation():
    with pytest.raises(InvalidDesignError) as ei:
        WhiskerDesign(l=1.0, x_ss=0.0).validate()
    assert len(ei.value.violations) >= 2


def test_ga_box_corners_are_valid():
    for a in (2.5, 6.0):
        for t in (2.0, 6.0):
            for l_ in (10.0, 15.0):
                for trim in (0.0, 5.0, 10.0):
                    WhiskerDesign(alpha=a, t=t, l=l_, trim=trim).validate()


def test_tan_alpha():
    assert WhiskerDesign(alpha=45 - 1e-9).tan_alpha == pytest.approx(1.0)
    assert WhiskerDesign().tan_alpha == pytest.approx(math.tan(math.radians(2.862)))
