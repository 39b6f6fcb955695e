# Post-processes fastddsgen's cpgmatch_msgsTypeObject.cxx (cmake -DFILE=... -P register_types_once.cmake).
#
# Every generated message constructor calls registercpgmatch_msgsTypes(), which registers every type with
# Fast DDS's TypeObjectFactory again (map look-ups and memcmp of type identifiers): perf showed it was half
# of the optimizer's event-thread time, since each candidate, trial record and parameter entry it builds
# constructs messages. Registering is idempotent, so the body now runs once (a thread-safe static).
file(READ "${FILE}" text)
set(signature "void registercpgmatch_msgsTypes()\n{")
string(FIND "${text}" "${signature}" at)
if(at EQUAL -1)
  message(FATAL_ERROR "${FILE}: '${signature}' not found; fastddsgen's output changed, update register_types_once.cmake")
endif()
string(REPLACE "${signature}" "static void registercpgmatch_msgsTypes_once();
void registercpgmatch_msgsTypes()
{
    static const bool registered = (registercpgmatch_msgsTypes_once(), true);
    (void)registered;
}
static void registercpgmatch_msgsTypes_once()
{" text "${text}")
file(WRITE "${FILE}" "${text}")
