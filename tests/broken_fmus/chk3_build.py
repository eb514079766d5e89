"""The FMI 3.0 test FMU's builders under their former module name (docs/compliance.md shows
``import chk3_build``): both test FMUs are built by tests/broken_fmus/chk_build.py."""
from chk_build import CHK3C_TOKEN, CHK3C_XML, chk3c_fmu, static_variant  # noqa: F401
