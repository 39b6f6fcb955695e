// Shared-memory segments that dead Fast DDS processes left behind. Fast DDS's shared-memory transport keeps
// a segment (and, per port, a segment and a named semaphore) in /dev/shm with a lock file beside it that its
// owner holds locked (flock) for as long as it lives; a SIGKILLed process never removes them, so every kill
// left 8 files and their memory behind. A lock file that can be locked has no living owner: its segment is
// a zombie. The same rule as Fast DDS's own `fastdds shm clean`, done in-process at each participant's start.
#pragma once

#include <filesystem>

namespace cpgmatch::dds {

struct ShmCleanup {
  int segments_removed = 0;  // data segments (fastrtps_<16 hex>) of dead processes
  int ports_removed = 0;     // port segments (fastrtps_port<N>) of dead processes
  int in_use = 0;            // segments and ports whose owner is alive (kept)
};

// Removes the zombie segments and ports in `dir`; never touches a file whose lock is held, nor one it cannot
// open (another user's). Never throws: a directory it cannot read is left alone.
ShmCleanup remove_dead_shm_segments(const std::filesystem::path& dir = "/dev/shm");

}  // namespace cpgmatch::dds
