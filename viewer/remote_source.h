// --server: the SHRM computed by a shrmd service (docs/server.md) through the client library
// (client/shrm_client.h): the environment file is uploaded when the server lacks it, the job runs
// remotely and the returned SHRM file (SHA-256 verified by the client) is read back. Built only
// when the service's client library is (CMake `if(TARGET shrm_client)`).
#ifndef SHRM_VIEWER_REMOTE_SOURCE_H_
#define SHRM_VIEWER_REMOTE_SOURCE_H_

#include <string>

#include "viewer/scene_source.h"

namespace shrm::viewer {

// Each call connects (target "host:port"), uploads what is missing, runs Prefilter (kind global)
// and converts the answer; progress events are forwarded to the hook.
ShrmComputeFn RemoteCompute(const std::string& server, const std::string& env_path);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_REMOTE_SOURCE_H_
