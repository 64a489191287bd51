"""The package version is the HTTP contract's version (python/fragsim/_version.py)."""

import re
import unittest

import fragsim
from tests.support import ROOT


class VersionTest(unittest.TestCase):
    def test_package_version_is_the_contract_version(self):
        contract = fragsim.contract_version((ROOT / "api" / "openapi.yaml").read_text())
        self.assertEqual(fragsim.__version__, contract,
                         "api/openapi.yaml info.version changed: update python/fragsim/_version.py "
                         "(and the client, if routes or bodies changed)")
        self.assertEqual(fragsim.API_VERSION, contract)

    def test_pyproject_takes_the_version_from_the_package(self):
        text = (ROOT / "python" / "pyproject.toml").read_text()
        self.assertIn('dynamic = ["version"]', text)
        self.assertRegex(text, r'version = \{attr = "fragsim\._version\.__version__"\}')
        self.assertIsNone(re.search(r'^version\s*=\s*"', text, re.M), "a static version too")

    def test_contract_version_reads_info_version_only(self):
        doc = "openapi: 3.0.3\ninfo:\n  title: x\n  version: 2.3.4\npaths:\n  version: 9\n"
        self.assertEqual(fragsim.contract_version(doc), "2.3.4")
        with self.assertRaises(ValueError):
            fragsim.contract_version("openapi: 3.0.3\n")


if __name__ == "__main__":
    unittest.main()
