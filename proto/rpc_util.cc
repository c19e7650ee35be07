#include "proto/rpc_util.h"

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace wormdrag::rpc {

Result<std::string> ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::InvalidArgument(path + ": cannot open");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string EnvOr(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::string(v) : fallback;
}

Result<std::string> ResolveToken(const std::string& file, const std::string& flag) {
  if (file.empty()) return flag.empty() ? EnvOr(kTokenEnv, "") : flag;
  auto text = ReadText(file);
  if (!text.ok()) return Status::InvalidArgument("token file " + file + ": cannot open");
  const size_t a = text->find_first_not_of(" \t\r\n"), b = text->find_last_not_of(" \t\r\n");
  if (a == std::string::npos) return Status::InvalidArgument("token file " + file + ": empty");
  return text->substr(a, b - a + 1);
}

bool IsLoopbackAddress(const std::string& host_port) {
  const size_t colon = host_port.rfind(':');
  std::string host = colon == std::string::npos ? host_port : host_port.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

Result<std::shared_ptr<grpc::Channel>> MakeChannel(const ClientConfig& c) {
  if (c.server.empty())
    return Status::InvalidArgument(std::string("no server address: give --server HOST:PORT or set ") + kServerEnv);
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(c.max_message_mb * 1024 * 1024);
  args.SetMaxSendMessageSize(c.max_message_mb * 1024 * 1024);
  // Reconnect quickly after a coordinator restart (the worker also backs off itself).
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 2000);
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 100);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 100);
  std::shared_ptr<grpc::ChannelCredentials> creds;
  if (c.tls_ca.empty() && c.tls_cert.empty() && c.tls_key.empty()) {
    creds = grpc::InsecureChannelCredentials();
  } else {
    grpc::SslCredentialsOptions o;
    if (!c.tls_ca.empty()) {
      auto ca = ReadText(c.tls_ca);
      if (!ca.ok()) return ca.status().Annotate("--tls-ca");
      o.pem_root_certs = *ca;
    }
    if (!c.tls_cert.empty() || !c.tls_key.empty()) {
      if (c.tls_cert.empty() || c.tls_key.empty())
        return Status::InvalidArgument("mutual TLS needs both --tls-cert and --tls-key");
      auto cert = ReadText(c.tls_cert);
      if (!cert.ok()) return cert.status().Annotate("--tls-cert");
      auto key = ReadText(c.tls_key);
      if (!key.ok()) return key.status().Annotate("--tls-key");
      o.pem_cert_chain = *cert;
      o.pem_private_key = *key;
    }
    creds = grpc::SslCredentials(o);
  }
  return grpc::CreateCustomChannel(c.server, creds, args);
}

void Prepare(grpc::ClientContext* ctx, const std::string& token, double seconds) {
  if (!token.empty()) ctx->AddMetadata("authorization", "Bearer " + token);
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::microseconds(static_cast<int64_t>(seconds * 1e6)));
}

grpc::Status CheckToken(const grpc::ServerContext* ctx, const std::string& token) {
  if (token.empty()) return grpc::Status::OK;
  const auto& md = ctx->client_metadata();
  auto it = md.find("authorization");
  if (it == md.end())
    return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, "this server requires a token (--token or WORMDRAG_TOKEN)");
  const std::string got(it->second.data(), it->second.size());
  // Constant-time comparison: the token is a shared secret.
  const std::string want = "Bearer " + token;
  unsigned diff = got.size() == want.size() ? 0u : 1u;
  for (size_t i = 0; i < got.size() && i < want.size(); ++i) diff |= static_cast<unsigned>(got[i] ^ want[i]);
  if (diff != 0) return grpc::Status(grpc::StatusCode::UNAUTHENTICATED, "invalid token");
  return grpc::Status::OK;
}

grpc::Status ToGrpc(const Status& st) {
  if (st.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(static_cast<int>(st.code())), st.message());
}

Status FromGrpc(const grpc::Status& st) {
  if (st.ok()) return Status::Ok();
  const std::string m = st.error_message();
  switch (st.error_code()) {
    case grpc::StatusCode::CANCELLED:
      return Status::Cancelled(m);
    case grpc::StatusCode::INVALID_ARGUMENT:
      return Status::InvalidArgument(m);
    case grpc::StatusCode::NOT_FOUND:
      return Status::NotFound(m);
    case grpc::StatusCode::ALREADY_EXISTS:
      return Status::AlreadyExists(m);
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
      return Status::ResourceExhausted(m);
    case grpc::StatusCode::FAILED_PRECONDITION:
      return Status::FailedPrecondition(m);
    case grpc::StatusCode::UNIMPLEMENTED:
      return Status::Unimplemented(m);
    case grpc::StatusCode::UNAVAILABLE:
      return Status::Unavailable(m);
    case grpc::StatusCode::DEADLINE_EXCEEDED:
      return Status::Unavailable("deadline exceeded: " + m);
    case grpc::StatusCode::UNAUTHENTICATED:
      return Status::Unauthenticated(m);
    case grpc::StatusCode::PERMISSION_DENIED:
      return Status::PermissionDenied(m);
    default:
      return Status::Internal(m);
  }
}

}  // namespace wormdrag::rpc
