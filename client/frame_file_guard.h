#pragma once
// Frame files a user hands to pd (export, compare, plan) are opened by HDF5 first in a child
// process: HDF5 1.10 crashes on some damaged or crafted files (fuzz/known_hdf5_bugs/frame_file:
// h5f_accum_read_segv.h5 and h5hg_read_segv.h5 killed `pd export` with SIGSEGV), and a crash there
// must be a clear error, not pd dying. The child is pd itself (`pd check-frame-file FILE`, hidden),
// with 4 GiB of address space and 30 s; it opens the file as the command would (FrameReader's
// complete check, and the stored hierarchy when there is one). Costs one exec and one open per
// file (tens of milliseconds).
#include <string>

namespace pd::cli {

// The program the check runs as a child ("/proc/self/exe" in pd); empty (the default, e.g. in unit
// tests that call the commands in-process): no child, the file is opened directly.
void set_frame_file_checker(const std::string& program);

// Throws InputError naming the file when the child refuses it (its own message) or dies (which
// signal, and that the file is damaged or crafted); returns when the file opened cleanly.
void check_frame_file_in_child(const std::string& path);

// The child's side (`pd check-frame-file FILE`): caps its address space, opens the file; 0 when
// it opened, 2 with "pd: error: ..." on stderr when it was refused.
int check_frame_file_here(const std::string& path);

}  // namespace pd::cli
