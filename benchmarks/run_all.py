"""Run every benchmark of the repository one after the other (``make bench``).

Each benchmark prints a Markdown table; this collects them, with the machine's load
average before each one, into ``benchmarks/results.md``. The machines are shared
and noisy: run on a quiet machine, and compare figures measured side by side in one
run rather than across runs.
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
BENCHMARKS = ('bench_executor.py', 'bench_sim.py', 'bench_online.py', 'bench_lm.py',
              'bench_onnx.py', 'bench_identifier.py', 'bench_recorder.py', 'bench_graph.py',
              'bench_physical.py', 'bench_process.py')


def main() -> int:
    """Run the benchmarks that exist; return non-zero if one failed."""
    env = {**os.environ}
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    sections, failed = [], []
    for name in BENCHMARKS:
        script = HERE / name
        if not script.exists():
            continue
        load = os.getloadavg()[0]
        print(f'== {name} (load average {load:.2f})', flush=True)
        started = time.monotonic()
        result = subprocess.run([sys.executable, str(script)], env=env, text=True,
                                capture_output=True, check=False)
        print(result.stdout, result.stderr[-2000:] if result.returncode else '', flush=True)
        sections.append(f'## {name}\n\nload average before: {load:.2f}, took '
                        f'{time.monotonic() - started:.0f} s, exit {result.returncode}\n\n'
                        f'{result.stdout}\n')
        if result.returncode:
            failed.append(name)
    (HERE / 'results.md').write_text('# Benchmark results\n\n' + '\n'.join(sections))
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
