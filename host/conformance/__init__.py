"""The protocol conformance suite (``schmidt-fil conform``, docs/conformance.md).

A second, independent host written from the documents (docs/protocol.md, bus/schmidt.dbc, the EDS
files): pytest checks in ``check_*.py`` run against any python-can bus; :mod:`.plugin` holds the
options, node inventory and check records, :mod:`.link` the bus and clock, :mod:`.documents` what
the checks compare with, :mod:`.report` the JSON/Markdown report, :mod:`.emulator` the in-process
emulator as the device under test.
"""
