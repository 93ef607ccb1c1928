"""Test-suite layout: one folder per package (``estimator/``, ``recorder/``, ``replay/``,
``scripts/``); ``synthetic.py`` beside this file makes small logs for any of them.

pytest's default import mode puts this file's folder on ``sys.path``, so every test can
``from synthetic import write_log``.
"""
