"""The exact accumulators of the output sums (pmpm.kernels.exact_sum): the correctly
rounded sum (math.fsum's) whatever the order of the terms and their split into parts
(ranks), subnormal to near-overflow terms, and non-finite terms as a plain sum gives."""
import math

import numpy as np
import pytest

from pmpm.kernels import exact_sum


def total(*parts):
    """The rounded sum of the terms of ``parts`` each added into an accumulator of its
    own (a rank's) and the carried bins added, as the ranks' reduction does."""
    accs = []
    for terms in parts:
        acc = exact_sum.zeros(1)
        exact_sum.add_terms(acc, 0, np.ascontiguousarray(terms, np.float64))
        exact_sum.carry_all(acc)
        accs.append(acc)
    return exact_sum.rounded(sum(accs)[0])


@pytest.mark.parametrize("spread", [0, 20, 300])
def test_any_order_and_split_gives_the_correctly_rounded_sum(spread):
    rng = np.random.default_rng(spread)
    terms = rng.standard_normal(20_000) * 10.0 ** rng.integers(-spread, spread + 1, 20_000)
    expected = math.fsum(terms)
    assert total(terms) == expected
    assert total(terms[::-1]) == expected
    assert total(terms[::2], terms[1::2][::-1]) == expected
    assert total(terms[:7], terms[7:5000], terms[5000:]) == expected


def test_cancellation_and_the_extremes_of_the_range():
    assert total([0.1, 0.2, -0.3]) == math.fsum([0.1, 0.2, -0.3])
    assert total([1e16, 1.0, -1e16]) == 1.0 != sum([1e16, 1.0, -1e16])
    tiny = [5e-324, 1e-310, -3e-320, 2.2250738585072014e-308]
    assert total(tiny) == math.fsum(tiny)
    huge = [1.7976931348623157e308, -1.7976931348623157e308, 1.0, 1e-300]
    assert total(huge) == 1.0
    assert total([1.7976931348623157e308, 1.7976931348623157e308]) == math.inf
    assert total([-1.7976931348623157e308, -1.7976931348623157e308]) == -math.inf
    assert total([]) == 0.0 and total([-0.0]) == 0.0


def test_non_finite_terms_give_what_a_plain_sum_gives():
    assert total([math.inf, 1.0], [2.0]) == math.inf
    assert total([-math.inf], [1.0]) == -math.inf
    assert math.isnan(total([math.inf], [-math.inf]))
    assert math.isnan(total([1.0, math.nan]))


def test_the_bins_carry_before_they_overflow():
    """Terms whose 53 bits end one place below a bin boundary put 2**52 into the upper
    bin each: without the carries every CARRY_EVERY terms it would pass 2**63."""
    terms = np.full(5 * exact_sum.CARRY_EVERY + 3, 4.0 - 2.0 ** -50)
    assert total(terms) == math.fsum(terms)
