"""Preloaded by the local pool's forkserver only: the forkserver dies with the driver (Linux).

Python's forkserver exits only when every process holding its "alive" pipe has closed it,
and the pool workers hold it too, so a driver killed with -9 would leave the forkserver and
its workers running. Importing this module in the forkserver asks the kernel to SIGKILL it
when its parent, the driver, dies; each worker asks the same of the forkserver
(`conjure.experiments.executors`). Never import it elsewhere.
"""

from conjure.experiments.executors import die_with_parent

die_with_parent()
