"""The Python mirror is complete: every public header of the core has its binding file, and
every public data member of every struct or class it defines is an attribute of the bound
Python class (as Open3D checks its own bindings). A field added to a header without its
def_readwrite makes this test fail, naming the header, the type and the field.

Run by CTest with PYTHONPATH at the built module; PICOSCAN_SOURCE_DIR is the repository.
"""
import os
import sys
import unittest

import picoscan

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import header_members  # noqa: E402

SOURCE_DIR = os.environ.get("PICOSCAN_SOURCE_DIR",
                            os.path.abspath(os.path.join(os.path.dirname(__file__), os.pardir, os.pardir)))
INCLUDE_DIR = os.path.join(SOURCE_DIR, "core", "include", "picoscan")
BINDING_DIR = os.path.join(SOURCE_DIR, "core", "python")

# Types deliberately not bound as Python classes, with the reason.
UNBOUND_TYPES = {
    "Error": "raised as the exception picoscan.Error (a RuntimeError), not a class to construct",
}
# Data members deliberately not bound, with the reason: (type, member) -> reason.
UNBOUND_MEMBERS = {}
# Enums deliberately not bound, with the reason.
UNBOUND_ENUMS = {
    "Encoding": "the writers take ascii=True/False instead",
}


def all_headers():
    return header_members.header_paths(INCLUDE_DIR)


class ParserTest(unittest.TestCase):
    """The header reader itself, on declarations of the styles the headers use."""

    def test_reads_members_of_each_declaration_style(self):
        import tempfile
        text = """
        // comment with struct Fake { int no; };
        struct Plain { int a = 1; double b, c; cv::Vec3d d{0, 0, 1}; std::vector<std::pair<int, int>> e;
                       double f = std::nan(""); bool used() const { return a > 0; } int g[3]; };
        struct Small { double x = 0; double y = 0; };
        enum class Kind { One, Two };
        class Hidden : public Base {
        public:
            explicit Hidden(int value);
            ~Hidden() override;
            std::string name() const override { return "x"; }
            int visible_member = 0;
            static constexpr int kConstant = 3;
        private:
            struct Impl;
            std::unique_ptr<Impl> impl_;
            int hidden_ = 0;
        };
        """
        with tempfile.NamedTemporaryFile("w", suffix=".h", delete=False) as header:
            header.write(text)
        try:
            types = header_members.public_types(header.name)
            enums = header_members.public_enums(header.name)
        finally:
            os.unlink(header.name)
        self.assertEqual(types["Plain"], ["a", "b", "c", "d", "e", "f", "g"])
        self.assertEqual(types["Small"], ["x", "y"])
        self.assertEqual(types["Hidden"], ["visible_member"])
        self.assertNotIn("Fake", types)
        self.assertNotIn("Kind", types)
        self.assertEqual(enums["Kind"], ["One", "Two"])

    def test_reads_the_real_headers(self):
        """Spot checks on the real headers: a parser that silently reads nothing would pass
        the mirror test, so it must find known members."""
        calibration = header_members.public_types(os.path.join(INCLUDE_DIR, "calibration.h"))
        self.assertIn("projector_inverse_response", calibration["Calibration"])
        capture = header_members.public_types(os.path.join(INCLUDE_DIR, "capture.h"))
        self.assertEqual(capture["VideoCaptureCamera"], [])  # only private data
        self.assertEqual(capture["CameraSettings"],
                         ["resolution", "exposure", "gain", "focus", "white_balance_k", "flush_frames"])
        total = sum(len(members) for path in all_headers() for members in header_members.public_types(path).values())
        self.assertGreater(total, 250)


class MirrorTest(unittest.TestCase):
    def test_every_public_header_has_its_binding_file(self):
        missing = [os.path.basename(path) for path in all_headers()
                   if not os.path.exists(os.path.join(BINDING_DIR, os.path.basename(path)[:-2] + ".cpp"))]
        self.assertEqual(missing, [], "headers without core/python/<name>.cpp")

    def test_every_binding_file_belongs_to_a_header(self):
        headers = {os.path.basename(path)[:-2] for path in all_headers()}
        # module.cpp holds the module's table of contents and the cv::Mat <-> NumPy conversion.
        stray = [name for name in sorted(os.listdir(BINDING_DIR))
                 if name.endswith(".cpp") and name[:-4] not in headers and name != "module.cpp"]
        self.assertEqual(stray, [], "binding files that mirror no public header")

    def test_the_architecture_table_lists_every_header(self):
        """docs/architecture.md's stage table: one row per public header, naming its binding."""
        text = header_members.read_text(os.path.join(SOURCE_DIR, "docs", "architecture.md"))
        missing = [os.path.basename(path) for path in all_headers()
                   if f"| `{os.path.basename(path)}` | " not in text
                   or f"| `{os.path.basename(path)[:-2]}.cpp` |" not in text]
        self.assertEqual(missing, [], "headers without their row in docs/architecture.md")

    def test_every_type_and_field_is_bound(self):
        problems = []
        for path in all_headers():
            header = os.path.basename(path)
            for type_name, members in header_members.public_types(path).items():
                if type_name in UNBOUND_TYPES:
                    continue
                bound = getattr(picoscan, type_name, None)
                if not isinstance(bound, type):
                    problems.append(f"{header}: {type_name} is not bound")
                    continue
                for member in members:
                    if (type_name, member) not in UNBOUND_MEMBERS and not hasattr(bound, member):
                        problems.append(f"{header}: {type_name}.{member} is not bound")
        self.assertEqual(problems, [])

    def test_every_enum_value_is_bound(self):
        problems = []
        for path in all_headers():
            for enum_name, values in header_members.public_enums(path).items():
                if enum_name in UNBOUND_ENUMS:
                    continue
                bound = getattr(picoscan, enum_name, None)
                if bound is None:
                    problems.append(f"{os.path.basename(path)}: enum {enum_name} is not bound")
                    continue
                problems += [f"{enum_name}.{value} is not bound" for value in values if not hasattr(bound, value)]
        self.assertEqual(problems, [])

    def test_exceptions_name_what_exists(self):
        """An exception for a type or member that no longer exists is stale: remove it."""
        types = {}
        enums = {}
        for path in all_headers():
            types.update(header_members.public_types(path))
            enums.update(header_members.public_enums(path))
        self.assertEqual([name for name in UNBOUND_TYPES if name not in types], [])
        self.assertEqual([name for name in UNBOUND_ENUMS if name not in enums], [])
        self.assertEqual([key for key in UNBOUND_MEMBERS if key[1] not in types.get(key[0], [])], [])
        self.assertTrue(issubclass(picoscan.Error, RuntimeError))


if __name__ == "__main__":
    unittest.main()
