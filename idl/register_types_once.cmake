# Post-processes fastddsgen's <NAME>TypeObject.cxx (cmake -DFILE=... [-DNAME=cpgmatch_msgs] -P register_types_once.cmake),
# NAME being the IDL file's name without .idl.
#
# Every generated message constructor calls registercpgmatch_msgsTypes(), which registers every type with
# Fast DDS's TypeObjectFactory again (map look-ups and memcmp of type identifiers): perf showed it was half
# of the optimizer's event-thread time, since each candidate, trial record and parameter entry it builds
# constructs messages. Registering is idempotent, so the body now runs once (a thread-safe static).
if(NOT NAME)
  set(NAME cpgmatch_msgs)
endif()
file(READ "${FILE}" text)
set(signature "void register${NAME}Types()\n{")
string(FIND "${text}" "${signature}" at)
if(at EQUAL -1)
  message(FATAL_ERROR "${FILE}: '${signature}' not found; fastddsgen's output changed, update register_types_once.cmake")
endif()
string(REPLACE "${signature}" "static void register${NAME}Types_once();
void register${NAME}Types()
{
    static const bool registered = (register${NAME}Types_once(), true);
    (void)registered;
}
static void register${NAME}Types_once()
{" text "${text}")
file(WRITE "${FILE}" "${text}")
