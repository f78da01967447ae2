#pragma once
// Crash guard for OpenVDB's file reader. OpenVDB 10.0 overflows a heap buffer on a corrupt blosc
// chunk size (io::bloscFromStream reads before it checks the size) and allocates up to 4 GB from
// 32-bit lengths in a file, so a crafted .vdb can abort fogmap instead of failing with a message.
// Before fogmap reads a VDB file, the fogmap binary reads it once in a child process
// (`fogmap __probe-vdb FILE`, hidden from --help) under a memory and CPU-time limit that grow with
// the file's size (never a wall-clock limit: a busy machine must not fail a valid file); a crash
// there becomes an InputError here. The child dies with its parent (PR_SET_PDEATHSIG), so killing
// fogmap leaves no orphan reading on. Off unless main() enables it: library users and unit tests
// read files directly. Process-wide state (like the logger), guarded by a mutex: thread-safe.

#include <string>

namespace fogmap {

/// What is checked of a VDB file before OpenVDB (or the probe) opens it: a regular file (not a
/// FIFO or device) whose header, grid descriptors and every grid's data end within its size:
/// OpenVDB does not check its stream, and reads a grid cut short as an empty grid. Stateless,
/// works with the probe off. Throws InputError{path, field, reason}.
void check_vdb_file(const std::string& path, const std::string& field);

/// Turns the probe on for this process; `self_exe` is the fogmap binary to re-run (main passes
/// "/proc/self/exe").
void enable_vdb_probe(std::string self_exe);

/// Reads every grid of `path` in a child process first. No-op when the probe is off or `path`
/// passed before in this process. `field` is the JSON pointer quoted in errors. Throws
/// InputError{path, field, vdb_error_reason(OpenVDB's message)} when the child reports an
/// error, or "corrupt VDB file: OpenVDB's reader crashed on it (signal N)" (or did not finish
/// within its CPU seconds); std::runtime_error when the child cannot be started.
void probe_vdb(const std::string& path, const std::string& field);

/// The child side (`fogmap __probe-vdb FILE`): limits its address space, CPU time and core
/// dumps, opens
/// `path` and reads every grid, writes no file. Returns 0, or prints the reason on stdout and
/// returns 2.
int run_vdb_probe_child(const std::string& path);

/// One printable line saying what an exception thrown while OpenVDB read a file means for the
/// file ("corrupt VDB file: a compressed block of voxel data does not decompress to its stated
/// size"), instead of OpenVDB's own text, which names its internals and may quote garbage bytes.
std::string vdb_error_reason(const std::string& what);

}  // namespace fogmap
