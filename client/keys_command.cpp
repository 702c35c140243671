// pd keys PREFIX: a CURVE key pair for a worker or a client of a farm beyond loopback (farm/curve.h;
// docs/farm.md, "Authentication"). The scheduler's own pair comes from pd-scheduler --generate-keys,
// which writes the same two files.
#include <cstdio>

#include "commands.h"
#include "farm/curve.h"

namespace pd::cli {

int keys(const KeysArgs& args) {
  const farm::CurveKeyPair pair = farm::generate_key_pair();
  farm::write_key_pair(args.prefix, pair);  // refuses to replace an existing file
  std::printf("wrote %s.key (this peer's --key; keep it private) and %s.pub (add it to the scheduler's "
              "--authorized-keys)\npublic key: %s\n",
              args.prefix.c_str(), args.prefix.c_str(), pair.public_key.c_str());
  return 0;
}

}  // namespace pd::cli
