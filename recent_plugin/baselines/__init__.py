"""The baselines RECENT is compared with (registered as methods in ``recent_plugin/methods/baselines.py``).

They share RECENT's FIM infiller, validation gate and executor, and differ in what the LM is asked
and in how failures are handled (the paper's appendix "Baseline Implementations"):

* ``cap`` — Code-as-Policies: the whole program from the task description, the target robot's
  primitive list and an in-context example (the Panda reference skill); on a failure the error
  is appended and the whole program is regenerated and run again from the current state.
* ``repair`` — RepairAgent-style: generate as ``cap``, then repair with *failure-localized* edits:
  only the failing statement is regenerated, with the error and the current scene in the prompt.
* ``agentless`` — a constraint-aware prompt (primitive specifications, scene objects, workspace
  bounds); on a failure the failing line is regenerated first, then the whole function.

Generated code still passes validation before it runs (no LM output is ever executed unchecked):
a program the gate rejects is what would have raised at run time, so it is answered the way the
baseline answers an execution error, and counted as one (EI, IT).
"""
