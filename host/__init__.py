"""The operator's side of schmidt-fil: host client, logs, scenario runner, reports, the CLI.

``host/network.py`` is the one place where boards, bus and plant are wired together.
"""
