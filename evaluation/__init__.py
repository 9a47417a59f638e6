"""The paper's evaluation on our suites: RECENT, its ablations and the baselines, side by side.

``methods`` names what is compared, ``runner`` runs the episodes (resumable, in parallel),
``metrics`` computes SR, GC, GO, EI, IT and IGT as the paper's appendix defines them, and
``report`` renders the tables and plots. ``recent bench`` is the command line.
"""
