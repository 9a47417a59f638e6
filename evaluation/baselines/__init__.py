"""The baselines RECENT is compared with, one module each (``cap.py``, ``repair.py``, ``scot.py``,
``progprompt.py``, ``roboinspector.py``, ``agentless.py``), each a registered method with its prompt
strategy (a :class:`~.program_prompt.BaselineStyle`); ``base.py`` is what they share.

They share RECENT's FIM infiller, validation gate and executor, and differ in what the LM is asked
and in how failures are handled (the paper's appendix "Baseline Implementations"):

* ``cap`` — Code-as-Policies: the whole program from the task description, the target robot's
  primitive list and an in-context example (the Panda reference skill); on a failure the error
  is appended and the whole program is regenerated and run again from the current state.
* ``repair`` — RepairAgent-style: generate as ``cap``, then repair with *failure-localized* edits:
  only the failing statement is regenerated, with the error and the current scene in the prompt.
* ``agentless`` — a constraint-aware prompt (primitive specifications, scene objects, workspace
  bounds); on a failure the failing line is regenerated first, then the whole function.

One protocol for every method, as in the paper: generated programs run in the simulator until
they fail. Every program passes the security gate first (no LM output runs unchecked for safety);
the baselines get no interface validation, so a wrong primitive, keyword or name fails when it is
reached with Python's own error (NameError, TypeError, AttributeError), categorised in the
paper's taxonomy, fed back as the baseline does, and what ran before it counts for GC.
"""
