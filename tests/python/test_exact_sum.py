"""ExactSum (lib/core/exact_sum.h) against math.fsum, which is correctly
rounded: random values over a wide exponent range, summed by
tests/exact_sum_probe; its Terms must fsum to the same double."""

import math
import os
import random
import subprocess
import unittest

PROBE = os.environ["MESHGAUGE_EXACT_SUM_PROBE"]


def probe(values):
    text = "".join(v.hex() + "\n" for v in values)
    out = subprocess.run([PROBE], input=text, capture_output=True,
                         text=True, check=True).stdout.splitlines()
    terms = [float.fromhex(t) for t in out[1].split()] if len(out) > 1 else []
    return float.fromhex(out[0]), terms


class ExactSumTest(unittest.TestCase):
    def test_matches_fsum_on_wide_random_values(self):
        rng = random.Random(54)
        for case in range(40):
            n = rng.randint(1, 3000)
            values = [math.ldexp(rng.uniform(-1, 1), rng.randint(-1070, 1000))
                      for _ in range(n)]
            if case % 2:  # cancellation: values and most of their negatives
                values += [-v for v in values[: n - 3]]
            rng.shuffle(values)
            rounded, terms = probe(values)
            self.assertEqual(rounded.hex(), math.fsum(values).hex(), case)
            self.assertEqual(math.fsum(terms).hex(), rounded.hex(), case)
            if terms:
                self.assertEqual(terms[0], rounded)

    def test_known_cases(self):
        self.assertEqual(probe([1e308, 1.0, -1e308])[0], 1.0)
        self.assertEqual(probe([1.0, 2.0 ** -53])[0], 1.0)
        tiny = 5e-324
        self.assertEqual(probe([tiny, tiny, tiny])[0], math.fsum([tiny] * 3))


if __name__ == "__main__":
    unittest.main()
