# Runs one fuzz target for SECONDS on a fresh corpus: fuzz_seeds writes it into a temp folder,
# which is removed afterwards (crash reproducers, if any, are kept in the build folder).
# Usage: cmake -DKIND=scene|vdb -DFUZZER=... -DSEEDS=... -DSECONDS=60 -DSOURCE_DIR=... -P this
string(RANDOM LENGTH 8 suffix)
set(corpus "$ENV{TMPDIR}")
if(NOT corpus)
  set(corpus "/tmp")
endif()
set(corpus "${corpus}/fogmap_fuzz_${KIND}_${suffix}")
file(MAKE_DIRECTORY "${corpus}")
execute_process(COMMAND "${SEEDS}" "${KIND}" "${SOURCE_DIR}" "${corpus}" RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  file(REMOVE_RECURSE "${corpus}")
  message(FATAL_ERROR "fuzz_seeds failed (${rc})")
endif()
# OpenVDB trusts 32-bit lengths read from the file (e.g. MetaMap::readMeta, grid descriptors):
# a corrupt file makes it allocate and fill up to 4 GB before the read fails (an OpenVDB
# limitation, reported; under ASan each costs ~20 s). Fork mode runs inputs in child processes
# and, with -ignore_ooms/-ignore_timeouts, counts such inputs (mallocs over 256 MB, units over
# 20 s) and goes on; crashes and sanitizer reports still end the run with an error. OpenVDB also
# leaks the partly read tree when a read throws (libopenvdb frames only): leak detection is off.
set(ENV{ASAN_OPTIONS} "detect_leaks=0")
execute_process(COMMAND "${FUZZER}" -fork=1 -ignore_ooms=1 -ignore_timeouts=1
                        -max_total_time=${SECONDS} -malloc_limit_mb=256 -rss_limit_mb=2048
                        -timeout=20 -max_len=131072 -print_final_stats=1 "${corpus}"
                RESULT_VARIABLE rc)
file(REMOVE_RECURSE "${corpus}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "fuzz_${KIND} found a failure (exit ${rc}); the reproducer is crash-* in "
                      "the working folder")
endif()
