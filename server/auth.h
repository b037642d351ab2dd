// Bearer-token authentication and transport credentials of shrmd (docs/server.md, "Security").
// Tokens come from a file (one a line); every call must carry `authorization: Bearer <token>`,
// compared in constant time. Tokens are never logged. gRPC 1.51 runs an AuthMetadataProcessor
// only on secure credentials, so a token-protected server uses TLS or, on loopback only,
// local credentials (LOCAL_TCP).
#ifndef SHRM_SERVER_AUTH_H_
#define SHRM_SERVER_AUTH_H_

#include <grpcpp/grpcpp.h>
#include <grpcpp/security/auth_metadata_processor.h>

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace shrm::server {

struct SecurityOptions {
  std::string token_file;     // bearer tokens, one a line ('#' comments, blanks ignored)
  std::string tls_cert_file;  // PEM server certificate chain
  std::string tls_key_file;   // PEM private key
  std::string tls_client_ca;  // PEM CA: client certificates are required and verified
};

// Reads the tokens of `path`: one a line, surrounding whitespace trimmed, blank lines and lines
// starting with '#' skipped. Errors name the file, never a token.
absl::StatusOr<std::vector<std::string>> ReadTokenFile(const std::string& path);

// True when a and b are equal; the time taken depends only on their lengths.
bool ConstantTimeEquals(std::string_view a, std::string_view b);

// True for a listen address on the loopback interface ("127.x.x.x:P", "[::1]:P", "localhost:P").
bool IsLoopbackAddress(const std::string& listen);

// Checks `authorization: Bearer <token>` against the configured tokens; UNAUTHENTICATED when it
// is missing or wrong. Health checks (grpc.health.v1.Health) pass without a token so that probes
// need no secret.
class BearerTokenProcessor : public grpc::AuthMetadataProcessor {
 public:
  explicit BearerTokenProcessor(std::vector<std::string> tokens) : tokens_(std::move(tokens)) {}
  bool IsBlocking() const override { return false; }
  grpc::Status Process(const InputMetadata& auth_metadata, grpc::AuthContext* context,
                       OutputMetadata* consumed_auth_metadata,
                       OutputMetadata* response_metadata) override;

 private:
  std::vector<std::string> tokens_;
};

// The server credentials for `listen`: TLS (mutual with tls_client_ca) when a certificate is
// given; else local credentials on loopback when tokens are set (a non-loopback address is
// refused: tokens would travel in clear); else insecure. Installs the token processor.
absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> MakeServerCredentials(
    const SecurityOptions& options, const std::string& listen);

}  // namespace shrm::server

#endif  // SHRM_SERVER_AUTH_H_
