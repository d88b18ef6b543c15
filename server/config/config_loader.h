// Loading the server config: protobuf TEXT format against msgs/proto/config.proto, converted into
// ServerParams (server_params.h) and validated.
//
//   core::Result<ServerParams> params = LoadConfigFile("config/slamd.textproto");
//
// Unset fields keep ServerParams' defaults; an empty text gives ServerParams{}. Errors are
// InvalidArgument with the source, 1-based line and column and the field:
//   "slamd.textproto:3:1: Message type "slamd.proto.QueueConfig" has no field named "deph"."
//   "slamd.textproto:4:3: queue.depth = 0; violates >= 1"
// Thread-safe (no state); never throws.
#pragma once

#include <string>

#include "core/base/status.h"
#include "server/config/server_params.h"

namespace slamd::server {

// Parses `text`; `source` names it in error messages.
core::Result<ServerParams> ParseConfigText(const std::string& text,
                                           const std::string& source = "<config>");

// Reads and parses the file at `path` (NotFound / IoError when it cannot be read).
core::Result<ServerParams> LoadConfigFile(const std::string& path);

// A commented config in text format holding every default of ServerParams{} (what
// `slamd --print-default-config` prints); ParseConfigText of it gives ServerParams{}.
std::string DefaultConfigText();

}  // namespace slamd::server
