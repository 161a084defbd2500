"""The bottom layer: what every other room uses and nothing of xcheck's own it imports.

- :mod:`.errors`: :class:`~.errors.UserError`, the base of every refusal a user can cause (exit 2 by its type);
- :mod:`.files`: output paths checked before any work, atomic writes, stamped folders (written hidden, renamed into
  place when complete, ``latest`` moved then), folders held by one process;
- :mod:`.interrupts`: Ctrl-C and SIGTERM as exceptions that unwind, held back where files land together, and the
  progress bar;
- :mod:`.pool`: worker processes that die with their parent and stop at once;
- :mod:`.executors`: where tasks run (this process, the pool, a Dask cluster) behind one interface.
"""
