"""The course's number formatting (``motionlab.text``): one style in every notebook."""
import math

import pytest

from motionlab import text


def test_percent_has_the_checks_spacing_and_rounds():
    assert text.pct(0.654) == "65 %"
    assert text.pct(0.0131, 1) == "1.3 %"
    assert text.pct(1.05) == "105 %"
    assert text.pct(-0.26) == "\u221226 %"


def test_negative_numbers_get_a_minus_sign_not_a_hyphen():
    assert text.num(-507) == "\u2212507"
    assert text.num(-3.14159, 1) == "\u22123.1"
    assert text.num(12400.4, thousands=True) == "12,400"
    assert text.num(-0.04, 1) == "0.0"          # rounds to zero: no sign
    assert "-" not in text.num(-2.5, 2)


def test_names_reads_as_a_list_and_refuses_ambiguous_names():
    assert text.names([]) == "none"
    assert text.names(["MoGlow"]) == "MoGlow"
    assert text.names(["VAE-LSTM", "MoGlow", "MoGlow (anchored)"]) == "VAE-LSTM, MoGlow and MoGlow (anchored)"
    with pytest.raises(ValueError, match="comma"):
        text.names(["VAE-LSTM", "MoGlow, anchored"])


@pytest.mark.parametrize("bad", [math.nan, math.inf, "x", None])
def test_non_numbers_are_refused(bad):
    with pytest.raises(ValueError, match="value|fraction"):
        text.num(bad)
    with pytest.raises(ValueError, match="fraction"):
        text.pct(bad)


def test_digits_must_be_a_small_whole_number():
    with pytest.raises(ValueError, match="digits"):
        text.num(1.0, -1)
    with pytest.raises(ValueError, match="digits"):
        text.num(1.0, 2.5)
