#pragma once
// A child process that must not outlive the process that started it (pd run's scheduler and workers,
// a test's farm): the kernel sends it `signal` when its parent dies, however the parent died
// (SIGKILL included, which runs no destructor and no handler). Linux only (PR_SET_PDEATHSIG).
#include <sys/types.h>

namespace pd {

// Asks for `signal` when the parent dies, then checks that the parent is still `expected_parent`:
// when it already died between the child's start and this call (the child was re-parented, and the
// kernel will send nothing), the signal is raised at once. Throws std::system_error when the kernel
// refuses the request. Note: the kernel sends it when the parent's *thread* that started the child
// ends, so start such children from a thread that lives as long as they should.
void exit_with_parent(pid_t expected_parent, int signal);

}  // namespace pd
