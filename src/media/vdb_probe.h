#pragma once
// Crash guard for OpenVDB's file reader. OpenVDB 10.0 overflows a heap buffer on a corrupt blosc
// chunk size (io::bloscFromStream reads before it checks the size) and allocates up to 4 GB from
// 32-bit lengths in a file, so a crafted .vdb can abort fogmap instead of failing with a message.
// So fogmap never reads a VDB file's voxels itself: a child process (`fogmap __probe-vdb ... FILE`,
// hidden from --help) reads the file and sends back what fogmap needs of it (the density grids'
// samplers, or `fogmap info`'s figures), under a memory and CPU-time limit that grow with the
// file's size and with what the child builds (never a wall-clock limit: a busy machine must not
// fail a valid file); a crash there becomes an InputError here. The file is read once, and the
// parent never holds OpenVDB's tree. The child dies with its parent (PR_SET_PDEATHSIG), so
// killing fogmap leaves no orphan reading on. Off unless main() enables it: library users and
// unit tests read files in their own process. Process-wide state (like the logger), guarded by a
// mutex: thread-safe.

#include "core/fd_stream.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace fogmap {

/// What is checked of a VDB file before OpenVDB (or the child) opens it: a regular file (not a
/// FIFO or device) whose header, grid descriptors and every grid's data end within its size:
/// OpenVDB does not check its stream, and reads a grid cut short as an empty grid. Stateless,
/// works with the probe off. Throws InputError{path, field, reason}.
void check_vdb_file(const std::string& path, const std::string& field);

/// Turns the probe on for this process; `self_exe` is the fogmap binary to re-run (main passes
/// "/proc/self/exe").
void enable_vdb_probe(std::string self_exe);

/// Whether files are read in a child (enable_vdb_probe was called).
bool vdb_probe_enabled();

/// What a reader child may use beyond reading its file: for what it builds from it.
struct ChildNeeds {
    double cpu_s = 0.0;
    uint64_t bytes = 0;
};

/// Runs `fogmap __probe-vdb ARGS... --cpu-seconds S --memory-bytes B -- path` and has `receive`
/// read the result the child sends (run_reader_child), then waits for the child. `field` is the
/// JSON pointer quoted in errors. Throws InputError{path, field, reason}: the child's own message
/// (its InputError's reason, or vdb_error_reason of OpenVDB's), "corrupt VDB file: OpenVDB's
/// reader crashed on it (signal N)", or did not finish within its CPU seconds;
/// std::runtime_error when the child cannot be started; std::logic_error when the probe is off.
void read_in_child(const std::string& path, const std::string& field,
                   const std::vector<std::string>& args, const ChildNeeds& needs,
                   const std::function<void(FdReader&)>& receive);

/// The child side: limits its core dumps, CPU seconds and address space, then calls `send` with
/// its stdout, which builds its result, writes send_result_mark and then the result. Returns 0;
/// or prints the reason of what `send` threw (one line) and returns 2.
int run_reader_child(const std::string& path, double cpu_s, uint64_t as_bytes,
                     const std::function<void(FdWriter&)>& send);
/// What a result starts with (a message never does).
void send_result_mark(FdWriter& out);

/// One printable line saying what an exception thrown while OpenVDB read a file means for the
/// file ("corrupt VDB file: a compressed block of voxel data does not decompress to its stated
/// size"), instead of OpenVDB's own text, which names its internals and may quote garbage bytes.
std::string vdb_error_reason(const std::string& what);

}  // namespace fogmap
