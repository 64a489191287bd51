"""The package version, which is the HTTP contract version it speaks.

``__version__`` equals ``info.version`` of ``api/openapi.yaml`` (the contract fragsimd serves at
``GET /v1/openapi.yaml``): the client of contract 0.2.0 is the package 0.2.0. pyproject.toml
reads the version from here; ``python/tests/test_version.py`` fails when the two drift apart, so a
change of the contract's version must come with this file (and, when routes or bodies changed,
the client code).
"""

__version__ = "0.2.0"

#: The fragsimd HTTP contract (``api/openapi.yaml`` ``info.version``) this client was written for.
API_VERSION = __version__
