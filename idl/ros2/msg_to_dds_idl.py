#!/usr/bin/env python3
"""ROS 2 .msg files -> the DDS IDL a ROS 2 RMW puts on the wire for them, without ROS.

    msg_to_dds_idl.py PACKAGE OUT.idl MSG_FILE...

The .msg files of idl/ros2/cpgmatch_msgs are the one source of truth of cpgmatch's ROS 2 view: colcon
builds them into a ROS 2 package, and this script turns them into what rosidl_generator_dds_idl makes of
them, so that cpgmatch (Fast DDS, fastddsgen) and tests (Cyclone DDS, idlc) speak the very types a ROS 2
node subscribes to, under the names ROS 2 gives them:

  * message Foo of package pkg  ->  struct pkg::msg::dds_::Foo_   (the DDS type name rmw_fastrtps and
                                                                  rmw_cyclonedds register)
  * field bar                   ->  member bar_                   (rosidl appends '_' so that no field name
                                                                  collides with an IDL keyword)
  * constant BAZ                ->  const BAZ_ in module pkg::msg::dds_::Foo_Constants (rosidl has no
                                                                  enums: .msg constants stand in for them)
  * uint8/int8/byte/char -> octet, int32 -> long, uint64 -> unsigned long long, ... (rosidl's "implicit"
    IDL names, which every IDL compiler knows); string<=N -> string<N>; T[N] -> array, T[] -> sequence<T>,
    T[<=N] -> sequence<T, N>.

All messages go into one IDL file, each after the messages it uses. Structs are @final and unkeyed: plain
XCDR1 as ROS 2 sends it. Defaults in .msg files do not change the wire type and are dropped.

Bad input stops with "FILE:LINE: what is wrong" on stderr and exit code 2.
"""
import os
import re
import sys

PRIMITIVES = {
    "bool": "boolean",
    "byte": "octet",
    "char": "octet",
    "int8": "octet",
    "uint8": "octet",
    "int16": "short",
    "uint16": "unsigned short",
    "int32": "long",
    "uint32": "unsigned long",
    "int64": "long long",
    "uint64": "unsigned long long",
    "float32": "float",
    "float64": "double",
    "string": "string",
    "wstring": "wstring",
}
INTEGERS = {"byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64"}

# ROS 2's naming rules (rosidl_adapter): fields lower_snake_case without a trailing or doubled '_',
# constants UPPER_CASE, messages CamelCase.
FIELD_NAME = re.compile(r"^[a-z](?:[a-z0-9]|_(?!_))*(?<!_)$")
CONSTANT_NAME = re.compile(r"^[A-Z](?:[A-Z0-9]|_(?!_))*(?<!_)$")
MESSAGE_NAME = re.compile(r"^[A-Z][A-Za-z0-9]*$")
# TYPE[<=N] [ARRAY]: base (primitive or [pkg/]Message), optional string bound, optional array suffix.
TYPE = re.compile(r"^(?:(?P<pkg>[a-z][a-z0-9_]*)/)?(?P<base>[A-Za-z][A-Za-z0-9_]*)"
                  r"(?:<=(?P<strbound>[0-9]+))?(?:\[(?P<array>(?:<=)?[0-9]*)\])?$")


class MsgError(Exception):
    pass


class Field:
    def __init__(self, type_text, name, where):
        m = TYPE.match(type_text)
        if not m:
            raise MsgError(f"{where}: '{type_text}' is not a ROS 2 field type")
        self.pkg, self.base = m.group("pkg"), m.group("base")
        self.string_bound = m.group("strbound")
        self.array = m.group("array")  # None: no array; "": unbounded; "N": fixed; "<=N": bounded
        if self.string_bound is not None and self.base not in ("string", "wstring"):
            raise MsgError(f"{where}: only strings take a bound (<=N), not '{type_text}'")
        if self.array is not None and self.array not in ("", "<=") and int(self.array.lstrip("<=")) == 0:
            raise MsgError(f"{where}: an array of size 0 in '{type_text}'")
        if self.array == "<=":
            raise MsgError(f"{where}: '{type_text}' has a bounded array without a bound")
        if self.base in PRIMITIVES and self.pkg is not None:
            raise MsgError(f"{where}: '{type_text}': a primitive type has no package")
        if self.base not in PRIMITIVES and not MESSAGE_NAME.match(self.base):
            raise MsgError(f"{where}: unknown type '{self.base}' (a primitive or a CamelCase message name)")
        if not FIELD_NAME.match(name):
            raise MsgError(f"{where}: field name '{name}' is not lower_snake_case (a-z, 0-9, single '_' between)")
        self.name = name

    def is_message(self):
        return self.base not in PRIMITIVES

    def element_type(self, package):
        if self.is_message():
            return f"{self.pkg or package}::msg::dds_::{self.base}_"
        idl = PRIMITIVES[self.base]
        return f"{idl}<{self.string_bound}>" if self.string_bound is not None else idl

    def member(self, package):
        element = self.element_type(package)
        if self.array is None:
            return f"{element} {self.name}_;"
        if self.array == "":
            return f"sequence<{element}> {self.name}_;"
        if self.array.startswith("<="):
            return f"sequence<{element}, {self.array[2:]}> {self.name}_;"
        return f"{element} {self.name}_[{self.array}];"


class Constant:
    def __init__(self, type_text, name, value, where):
        if type_text not in PRIMITIVES or type_text == "wstring":
            raise MsgError(f"{where}: constant {name}: type '{type_text}' is not a primitive type")
        if not CONSTANT_NAME.match(name):
            raise MsgError(f"{where}: constant name '{name}' is not UPPER_CASE")
        self.type, self.name = type_text, name
        value = value.strip()
        if type_text in INTEGERS:
            try:
                number = int(value, 0)
            except ValueError:
                raise MsgError(f"{where}: constant {name}: '{value}' is not an integer") from None
            # int8 goes out as an octet (rosidl_generator_dds_idl): its two's complement.
            self.literal = str(number + 256 if type_text == "int8" and number < 0 else number)
        elif type_text in ("float32", "float64"):
            try:
                self.literal = repr(float(value))
            except ValueError:
                raise MsgError(f"{where}: constant {name}: '{value}' is not a number") from None
        elif type_text == "bool":
            if value.lower() not in ("true", "false", "1", "0"):
                raise MsgError(f"{where}: constant {name}: '{value}' is not true or false")
            self.literal = "TRUE" if value.lower() in ("true", "1") else "FALSE"
        else:  # string
            text = value[1:-1] if len(value) >= 2 and value[0] == value[-1] and value[0] in "'\"" else value
            self.literal = '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


class Message:
    def __init__(self, path):
        self.path = path
        self.name = os.path.splitext(os.path.basename(path))[0]
        if not MESSAGE_NAME.match(self.name) or not path.endswith(".msg"):
            raise MsgError(f"{path}: a message file is named CamelCase.msg")
        self.fields, self.constants = [], []
        with open(path, encoding="utf-8") as f:
            for number, raw in enumerate(f, start=1):
                self._parse_line(raw, f"{path}:{number}")
        names = [x.name for x in self.fields] + [c.name for c in self.constants]
        for name in names:
            if names.count(name) > 1:
                raise MsgError(f"{path}: '{name}' is declared twice")

    def _parse_line(self, raw, where):
        line = raw.strip()
        if not line or line.startswith("#"):
            return
        parts = line.split(None, 1)
        if len(parts) < 2:
            raise MsgError(f"{where}: expected 'TYPE NAME', got '{line}'")
        type_text, rest = parts
        if "=" in rest.split("#", 1)[0] or (type_text == "string" and "=" in rest):
            name, value = rest.split("=", 1)
            if type_text != "string":
                value = value.split("#", 1)[0]  # a string constant's value runs to the end of the line
            self.constants.append(Constant(type_text, name.strip(), value, where))
            return
        rest = rest.split("#", 1)[0].split()
        # A field may have a default value after its name; it does not change the wire type.
        self.fields.append(Field(type_text, rest[0], where))

    def uses(self, package):
        return [f.base for f in self.fields if f.is_message() and (f.pkg or package) == package]


def ordered(messages, package):
    """Each message after the messages of this package it uses; refuses unknown ones and cycles."""
    by_name = {m.name: m for m in messages}
    done, out = set(), []

    def visit(message, path):
        if message.name in done:
            return
        if message.name in path:
            raise MsgError(f"{message.path}: messages use each other in a cycle: {' -> '.join(path + [message.name])}")
        for used in message.uses(package):
            if used not in by_name:
                raise MsgError(f"{message.path}: uses {package}/{used}, which is not among the .msg files given")
            visit(by_name[used], path + [message.name])
        done.add(message.name)
        out.append(message)

    for m in sorted(messages, key=lambda m: m.name):
        visit(m, [])
    for m in messages:
        for f in m.fields:
            if f.is_message() and f.pkg not in (None, package):
                raise MsgError(f"{m.path}: field {f.name}: types of other packages ({f.pkg}) are not supported")
    return out


def dds_idl(package, messages):
    lines = [f"// Generated by idl/ros2/msg_to_dds_idl.py from the {package} .msg files: do not edit.",
             "// The DDS types ROS 2 puts on the wire for them (rosidl_generator_dds_idl's mapping).",
             f"module {package} {{ module msg {{ module dds_ {{", ""]
    for m in ordered(messages, package):
        if m.constants:
            lines.append(f"module {m.name}_Constants {{")
            lines += [f"  const {PRIMITIVES[c.type]} {c.name}_ = {c.literal};" for c in m.constants]
            lines += ["};", ""]
        lines += ["@final", f"struct {m.name}_ {{"]
        # IDL has no empty structs: rosidl gives a message without fields this one member.
        lines += [f"  {f.member(package)}" for f in m.fields] or ["  octet structure_needs_at_least_one_member_;"]
        lines += ["};", ""]
    lines.append("}; }; };  // module " + package + "::msg::dds_")
    return "\n".join(lines) + "\n"


def main(argv):
    if len(argv) < 4:
        print("usage: msg_to_dds_idl.py PACKAGE OUT.idl MSG_FILE...", file=sys.stderr)
        return 2
    package, out, files = argv[1], argv[2], argv[3:]
    if not re.match(r"^[a-z][a-z0-9_]*$", package):
        print(f"PACKAGE: '{package}' is not a ROS 2 package name", file=sys.stderr)
        return 2
    try:
        text = dds_idl(package, [Message(f) for f in files])
    except (MsgError, OSError) as e:
        print(f"msg_to_dds_idl: {e}", file=sys.stderr)
        return 2
    with open(out, "w", encoding="utf-8") as f:
        f.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
