"""Loads the conformance plugin (options ``--cf-*``, fixtures ``conf``, ``check``, ``node``...)."""

from host.conformance.plugin import *  # noqa: F401,F403
from host.conformance.plugin import (conf, check, traffic, pytest_addoption, pytest_configure,  # noqa: F401
                                     pytest_generate_tests, pytest_collection_modifyitems,
                                     pytest_runtest_makereport, pytest_sessionfinish, pytest_pyfunc_call)
