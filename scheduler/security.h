#pragma once
// Who may talk to pd-scheduler: on loopback anyone on this machine (no keys needed); beyond
// loopback only CURVE peers whose public key is in the authorized-keys file (farm/curve.h).
// --key without --authorized-keys is refused as well: a CURVE server without a ZAP check admits any
// client that knows the server's public key, and a public key is meant to be handed around.
#include <initializer_list>
#include <memory>

#include <zmq.hpp>

#include "farm/curve.h"
#include "scheduler/scheduler.h"

namespace pd::scheduler {

// Checks the security options before anything is created: key_file and authorized_keys_file both
// or neither; both when an endpoint is not loopback; the files readable and well formed; CURVE in
// libzmq when they are given. Throws InputError saying which option is missing or which file is bad.
void check_security_options(const SchedulerOptions& options);

// Called before `sockets` bind. Without keys: checks that every endpoint is loopback, returns
// nullptr. With keys: starts the context's ZAP authenticator (admitting the authorized keys; the
// first refusal of each client key from each address is logged as a JSON "auth_refused" line on
// stderr), then makes every socket a CURVE server with the key pair; returns the authenticator,
// which must outlive the sockets (curve.h, "Lifetime"). Throws what check_security_options throws.
std::unique_ptr<farm::ZapAuthenticator> secure_sockets(zmq::context_t& ctx, const SchedulerOptions& options,
                                                       std::initializer_list<zmq::socket_t*> sockets);

}  // namespace pd::scheduler
