"""A command line that spends minutes inside one compiled call (``python -m tests.support.spin``): what a huge
batched evaluation does, for the tests of the interruption watchdog (:func:`jaxdc.cli.runner.stop_after_signal`).

It prints ``ready`` once the loop is compiled, then runs it for about 2**31 iterations."""

from __future__ import annotations

import jax
import jax.numpy as jnp


def main(argv=None) -> int:
    def spin(n):
        return jax.lax.while_loop(lambda c: c[0] < n, lambda c: (c[0] + 1, c[1] * 1.0000001 + 1e-9),
                                  (jnp.int32(0), jnp.float32(1.0)))[1]

    loop = jax.jit(spin)
    loop(jnp.int32(10)).block_until_ready()  # compiled: the next call is one long run of XLA code
    print("ready", flush=True)
    print(float(loop(jnp.int32(2**31 - 1))))
    return 0


if __name__ == "__main__":
    from jaxdc.cli.runner import entry

    entry("tests.support.spin", "spin")
