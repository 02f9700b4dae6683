"""The benchmarks' library: timed simulator rollouts, memory planning, the machine's line."""
