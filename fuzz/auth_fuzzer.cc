// shrmd's bearer-token and TLS options (server/auth.h): ReadTokenFile (one token a line,
// comments, whitespace), IsLoopbackAddress on the --listen text, MakeServerCredentials (which
// options go together, tokens in clear only on loopback, the PEM files read), and the token
// check every call goes through (BearerTokenProcessor::Process on the call's metadata).
//
// Input (FuzzedDataProvider): the token file, the listen address, the :path and authorization
// metadata, then which of the TLS files exist and their contents. Checked: a call passes only
// with "Bearer <t>" for a configured t, or on a health-check path; tokens without TLS are
// refused off loopback.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "fuzz/fuzz_util.h"
#include "server/auth.h"

namespace {

std::string MaybeFile(FuzzedDataProvider* fdp, const char* name) {
  if (!fdp->ConsumeBool()) return "";
  return shrm::fuzz::WriteScratchFile(name, fdp->ConsumeRandomLengthString(4096));
}

void CheckProcess(const std::vector<std::string>& tokens, const std::string& path,
                  const std::string& authorization, bool with_auth) {
  shrm::server::BearerTokenProcessor processor(tokens);
  grpc::AuthMetadataProcessor::InputMetadata in;
  in.insert({":path", path});
  if (with_auth) in.insert({"authorization", authorization});
  grpc::AuthMetadataProcessor::OutputMetadata consumed, response;
  const grpc::Status s = processor.Process(in, nullptr, &consumed, &response);
  const bool health = path.rfind("/grpc.health.v1.Health/", 0) == 0;
  bool valid = false;
  for (const std::string& t : tokens) valid |= with_auth && authorization == "Bearer " + t;
  shrm::fuzz::Check(s.ok() == (health || valid), "a call passes iff it carries a valid token");
  shrm::fuzz::Check(s.ok() || s.error_code() == grpc::StatusCode::UNAUTHENTICATED,
                    "a refused call is UNAUTHENTICATED");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider fdp(data, size);
  const std::string token_text = fdp.ConsumeRandomLengthString(4096);
  const std::string listen = fdp.ConsumeRandomLengthString(64);
  const std::string path = fdp.ConsumeRandomLengthString(64);
  const std::string authorization = fdp.ConsumeRandomLengthString(128);
  const bool with_auth = fdp.ConsumeBool();

  shrm::server::SecurityOptions options;
  const bool with_tokens = fdp.ConsumeBool();
  if (with_tokens) options.token_file = shrm::fuzz::WriteScratchFile("tokens", token_text);
  absl::StatusOr<std::vector<std::string>> tokens;
  if (with_tokens) {
    tokens = shrm::server::ReadTokenFile(options.token_file);
    if (tokens.ok()) {
      for (const std::string& t : *tokens)
        shrm::fuzz::Check(!t.empty() && t.front() != '#', "tokens are not blank or comments");
      CheckProcess(*tokens, path, authorization, with_auth);
    }
  }
  options.tls_cert_file = MaybeFile(&fdp, "cert.pem");
  options.tls_key_file = MaybeFile(&fdp, "key.pem");
  options.tls_client_ca = MaybeFile(&fdp, "ca.pem");
  const bool loopback = shrm::server::IsLoopbackAddress(listen);
  absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> creds =
      shrm::server::MakeServerCredentials(options, listen);
  if (creds.ok()) {
    shrm::fuzz::Check(*creds != nullptr, "credentials are made");
    shrm::fuzz::Check(!with_tokens || tokens.ok(), "an unreadable token file is refused");
    shrm::fuzz::Check(!with_tokens || !options.tls_cert_file.empty() || loopback,
                      "tokens in clear only on loopback");
    shrm::fuzz::Check(options.tls_cert_file.empty() == options.tls_key_file.empty(),
                      "--tls-cert and --tls-key go together");
  }
  return 0;
}
