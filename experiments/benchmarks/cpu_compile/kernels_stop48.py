"""Count thunk-level ops of one group's attempt program by source file."""

import sys
import time

import jax

from graspjax.batch import plan, program
from graspjax.config import Config

jax.config.update("jax_enable_compilation_cache", False)

gi = int(sys.argv[1])
groups = plan.plan([plan.table_job(1, 10), plan.table_job(2, 10)], [Config()], 0)
p = program.program(groups[gi], 10, False)
start, att = p.lower(0)
t = time.perf_counter()
c = att.compile()
print(f"compile {time.perf_counter() - t:.1f}s")
text = c.as_text()
open(f"/tmp/hlo_{gi}.txt", "w").write(text)
