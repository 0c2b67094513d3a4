// The calling thread's CPU time, for the timings the LOD tools report (lod_chain.cpp) and the
// measurement's own CPU figure (mesh_distance.cpp). Cost: one clock_gettime.
#pragma once

#include <time.h>

namespace hmdnode::lod_detail {

inline double thread_cpu_ms() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

}  // namespace hmdnode::lod_detail
