#!/usr/bin/env python3
"""idl/ros2/msg_to_dds_idl.py against rosidl's mapping of .msg files to DDS IDL (rosidl_generator_dds_idl):
type, member and constant names, every primitive, strings, arrays and sequences, messages after the messages
they use, and the errors for what ROS 2 itself would refuse.
    test_msg_to_dds_idl.py PATH/TO/msg_to_dds_idl.py"""
import os
import subprocess
import sys
import tempfile
import unittest

SCRIPT = None


def read(path):
    with open(path, encoding="utf-8") as f:
        return f.read()


def convert(files, package="demo_msgs"):
    """Writes {name: text} as .msg files, runs the script; returns (exit code, IDL text, stderr)."""
    with tempfile.TemporaryDirectory() as d:
        paths = []
        for name, text in files.items():
            paths.append(os.path.join(d, name))
            with open(paths[-1], "w", encoding="utf-8") as f:
                f.write(text)
        out = os.path.join(d, "out.idl")
        run = subprocess.run([sys.executable, SCRIPT, package, out] + paths, capture_output=True, text=True)
        idl = read(out) if os.path.exists(out) else ""
        return run.returncode, idl, run.stderr


def members(idl, struct):
    """The member lines of `struct` in `idl`."""
    lines = idl.splitlines()
    start = lines.index(f"struct {struct} {{") + 1
    end = lines.index("};", start)
    return [line.strip() for line in lines[start:end]]


class Mapping(unittest.TestCase):
    def test_names_are_rosidls(self):
        rc, idl, err = convert({"Pose2D.msg": "float64 x  # m\nfloat64 theta\n"})
        self.assertEqual(rc, 0, err)
        self.assertIn("module demo_msgs { module msg { module dds_ {", idl)
        self.assertIn("@final\nstruct Pose2D_ {", idl)  # Foo -> Foo_, unkeyed and final
        self.assertEqual(members(idl, "Pose2D_"), ["double x_;", "double theta_;"])  # bar -> bar_
        self.assertNotIn("@key", idl)

    def test_every_primitive(self):
        text = "".join(f"{t} f_{t}\n" for t in ["bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32",
                                                 "uint32", "int64", "uint64", "float32", "float64", "string",
                                                 "wstring"])
        rc, idl, err = convert({"All.msg": text})
        self.assertEqual(rc, 0, err)
        self.assertEqual(members(idl, "All_"), [
            "boolean f_bool_;", "octet f_byte_;", "octet f_char_;", "octet f_int8_;", "octet f_uint8_;",
            "short f_int16_;", "unsigned short f_uint16_;", "long f_int32_;", "unsigned long f_uint32_;",
            "long long f_int64_;", "unsigned long long f_uint64_;", "float f_float32_;", "double f_float64_;",
            "string f_string_;", "wstring f_wstring_;"])

    def test_strings_arrays_and_sequences(self):
        rc, idl, err = convert({"Shapes.msg": "string<=16 label\nfloat64[4] fixed\nint32[] unbounded\n"
                                              "uint8[<=8] bounded\nstring<=5[<=3] names\nint32 with_default 7\n"})
        self.assertEqual(rc, 0, err)
        self.assertEqual(members(idl, "Shapes_"), [
            "string<16> label_;", "double fixed_[4];", "sequence<long> unbounded_;", "sequence<octet, 8> bounded_;",
            "sequence<string<5>, 3> names_;", "long with_default_;"])

    def test_constants_go_into_a_constants_module(self):
        rc, idl, err = convert({"Mode.msg": "uint8 IDLE=0\nuint8 RUN=1  # running\nint8 BACK=-1\nfloat64 G=9.81\n"
                                            "bool ON=true\nstring NAME=a # b\nuint8 mode\n"})
        self.assertEqual(rc, 0, err)
        self.assertIn("module Mode_Constants {\n"
                      "  const octet IDLE_ = 0;\n"
                      "  const octet RUN_ = 1;\n"
                      "  const octet BACK_ = 255;\n"   # int8 goes out as an octet: two's complement
                      "  const double G_ = 9.81;\n"
                      "  const boolean ON_ = TRUE;\n"
                      '  const string NAME_ = "a # b";\n'  # a string constant runs to the end of the line
                      "};", idl)
        self.assertEqual(members(idl, "Mode_"), ["octet mode_;"])

    def test_a_message_comes_after_the_messages_it_uses(self):
        rc, idl, err = convert({"A.msg": "B[] bs\ndemo_msgs/C c\n", "B.msg": "C c\n", "C.msg": "int32 v\n"})
        self.assertEqual(rc, 0, err)
        self.assertLess(idl.index("struct C_"), idl.index("struct B_"))
        self.assertLess(idl.index("struct B_"), idl.index("struct A_"))
        self.assertEqual(members(idl, "A_"), ["sequence<demo_msgs::msg::dds_::B_> bs_;",
                                              "demo_msgs::msg::dds_::C_ c_;"])

    def test_an_empty_message_gets_rosidls_placeholder_member(self):
        rc, idl, err = convert({"Empty.msg": "# nothing\n"})
        self.assertEqual(rc, 0, err)
        self.assertEqual(members(idl, "Empty_"), ["octet structure_needs_at_least_one_member_;"])

    def test_the_shipped_package_converts(self):
        msg_dir = os.path.join(os.path.dirname(SCRIPT), "cpgmatch_msgs", "msg")
        files = {n: read(os.path.join(msg_dir, n)) for n in os.listdir(msg_dir)}
        rc, idl, err = convert(files, "cpgmatch_msgs")
        self.assertEqual(rc, 0, err)
        for struct in ["StudyState_", "TrialRecord_", "Worker_"]:
            self.assertIn(f"struct {struct} {{", idl)
        self.assertIn("const octet STATUS_STOPPED_ = 4;", idl)
        self.assertIn("sequence<string<32>, 32> best_param_names_;", idl)


class Errors(unittest.TestCase):
    def refused(self, files, *expected):
        rc, _, err = convert(files)
        self.assertEqual(rc, 2, err)
        for e in expected:
            self.assertIn(e, err)

    def test_bad_input_names_file_and_line(self):
        self.refused({"Bad.msg": "int32 ok\nfloat65 x\n"}, "Bad.msg:2:", "unknown type 'float65'")
        self.refused({"Bad.msg": "int32 camelCase\n"}, "Bad.msg:1:", "'camelCase' is not lower_snake_case")
        self.refused({"Bad.msg": "int32 trailing_\n"}, "Bad.msg:1:", "'trailing_'")
        self.refused({"Bad.msg": "uint8 lower=1\n"}, "Bad.msg:1:", "constant name 'lower' is not UPPER_CASE")
        self.refused({"Bad.msg": "uint8 X=one\n"}, "Bad.msg:1:", "'one' is not an integer")
        self.refused({"Bad.msg": "int32<=4 x\n"}, "Bad.msg:1:", "only strings take a bound")
        self.refused({"Bad.msg": "int32 x\nint32 x\n"}, "'x' is declared twice")
        self.refused({"bad.msg": "int32 x\n"}, "CamelCase.msg")

    def test_unknown_and_cyclic_messages(self):
        self.refused({"A.msg": "Missing m\n"}, "uses demo_msgs/Missing")
        self.refused({"A.msg": "B b\n", "B.msg": "A a\n"}, "cycle")
        self.refused({"A.msg": "geometry_msgs/Point p\n"}, "other packages (geometry_msgs)")


if __name__ == "__main__":
    SCRIPT = os.path.abspath(sys.argv.pop(1))
    unittest.main(verbosity=1)
