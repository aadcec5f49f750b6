"""atheris target: ``Config(**kwargs)`` from fuzzed dicts (names from the
real parameters and a few others, values of every kind). An accepted
configuration must validate, round-trip through ``to_dict`` and build a
filter."""

from __future__ import annotations

import math

import atheris
from harness import bs, main

_NAMES = [*bs.Config().to_dict(), "bogus", "", "rho", "init "]
_INITS = ["mte", "mte-clone", "mte-history", "pi-sr", "pi-sr-mixed", "ekf", ""]
_SPECIAL = [0.0, -0.0, 1.0, -1.0, math.nan, math.inf, -math.inf, 1e300, -1e-300, 5e-324]


def _value(fdp: atheris.FuzzedDataProvider) -> object:
    kind = fdp.ConsumeIntInRange(0, 9)
    if kind == 0:
        return fdp.ConsumeRegularFloat()
    if kind == 1:
        return _SPECIAL[fdp.ConsumeIntInRange(0, len(_SPECIAL) - 1)]
    if kind == 2:
        return fdp.ConsumeInt(9)
    if kind == 3:
        return fdp.ConsumeUnicodeNoSurrogates(12)
    if kind == 4:
        return _INITS[fdp.ConsumeIntInRange(0, len(_INITS) - 1)]
    if kind == 5:
        return tuple(fdp.ConsumeRegularFloat() for _ in range(fdp.ConsumeIntInRange(0, 7)))
    if kind == 6:
        return {
            fdp.ConsumeInt(9): (fdp.ConsumeRegularFloat(), fdp.ConsumeRegularFloat())
            for _ in range(fdp.ConsumeIntInRange(0, 3))
        }
    if kind == 7:
        return fdp.ConsumeBool()
    if kind == 8:
        return None
    return [fdp.ConsumeRegularFloat() for _ in range(fdp.ConsumeIntInRange(0, 4))]


def test_one_input(data: bytes) -> None:
    fdp = atheris.FuzzedDataProvider(data)
    kwargs = {
        _NAMES[fdp.ConsumeIntInRange(0, len(_NAMES) - 1)]: _value(fdp)
        for _ in range(fdp.ConsumeIntInRange(0, 6))
    }
    config = bs.Config(**kwargs)  # type: ignore[arg-type]
    config.validate()
    assert bs.Config(**config.to_dict()) == config, "Config(**c.to_dict()) != c"
    filt = bs.SlamFilter(config)
    assert filt.config == config


if __name__ == "__main__":
    main(test_one_input)
