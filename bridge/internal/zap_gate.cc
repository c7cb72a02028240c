#include "bridge/internal/zap_gate.h"

#include <atomic>
#include <cstring>
#include <stdexcept>

namespace iapsim::bridge::internal {
namespace {

// ZeroMQ's fixed endpoint for the ZAP handler of a context
constexpr char kZapEndpoint[] = "inproc://zeromq.zap.01";

std::vector<std::string> ReadFrames(zmq::socket_t& socket) {
  std::vector<std::string> frames;
  zmq::message_t frame;
  do {
    if (!socket.recv(frame, zmq::recv_flags::dontwait)) break;
    frames.emplace_back(static_cast<const char*>(frame.data()), frame.size());
  } while (frame.more());
  return frames;
}

std::string Z85(const uint8_t key[32]) {
  char text[41];
  if (zmq_z85_encode(text, key, 32) == nullptr) throw std::invalid_argument("z85 encoding failed");
  return text;
}

// the public key (Z85) of a Z85 secret key, and its 32 bytes in `raw` if given
std::string PublicKey(const std::string& secret_z85, std::string* raw) {
  char text[41];
  if (zmq_curve_public(text, secret_z85.c_str()) != 0) {
    throw std::invalid_argument("CURVE is not available in this libzmq");
  }
  if (raw) {
    uint8_t bytes[32];
    zmq_z85_decode(bytes, text);
    raw->assign(reinterpret_cast<const char*>(bytes), 32);
  }
  return text;
}

}  // namespace

ZapGate::ZapGate(zmq::context_t& context, Check check)
    : context_(context), zap_(context, zmq::socket_type::rep), check_(std::move(check)) {
  zap_.set(zmq::sockopt::linger, 0);
  zap_.bind(kZapEndpoint);
}

void ZapGate::Watch(zmq::socket_t& socket) {
  monitors_.push_back(MonitorSocket(context_, socket,
                                    ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL |
                                        ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL |
                                        ZMQ_EVENT_HANDSHAKE_FAILED_AUTH));
  watched_.push_back(socket.handle());
}

void ZapGate::StopWatching() {
  for (void* socket : watched_) zmq_socket_monitor(socket, nullptr, 0);
  watched_.clear();
}

void ZapGate::Serve() {
  while (true) {
    const std::vector<std::string> request = ReadFrames(zap_);
    if (request.empty()) break;
    // version, request id, domain, address, routing id, mechanism, credentials...
    std::string refusal = "a malformed authentication request";
    if (request.size() >= 6) {
      refusal = check_(ZapRequest{request[2], request[3], request[5],
                                  std::vector<std::string>(request.begin() + 6, request.end())});
      if (!refusal.empty() && !request[3].empty()) refusal += " (from " + request[3] + ")";
    }
    if (!refusal.empty()) Describe(refusal);
    const std::string reply[] = {"1.0",
                                 request.size() > 1 ? request[1] : "",
                                 refusal.empty() ? "200" : "400",
                                 refusal.empty() ? "OK" : refusal,
                                 "",
                                 ""};
    for (size_t i = 0; i < std::size(reply); ++i) {
      zap_.send(zmq::buffer(reply[i]),
                i + 1 < std::size(reply) ? zmq::send_flags::sndmore : zmq::send_flags::none);
    }
  }
  for (zmq::socket_t& monitor : monitors_) {
    for (const uint16_t id : TakeEvents(monitor)) {
      ++refused_;
      // a refused check was described by Serve; the others never reached it
      if (id != ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) {
        Describe("a peer without credentials (another security mechanism, or a broken handshake)");
      }
    }
  }
}

zmq::socket_t MonitorSocket(zmq::context_t& context, zmq::socket_t& socket, int events) {
  // one endpoint per monitor (inproc names are per context, but a process may have several contexts)
  static std::atomic<int> next{0};
  const std::string endpoint = "inproc://iapsim-monitor-" + std::to_string(next++);
  if (zmq_socket_monitor(socket.handle(), endpoint.c_str(), events) != 0) {
    throw std::runtime_error(std::string("cannot monitor a socket: ") + zmq_strerror(zmq_errno()));
  }
  zmq::socket_t monitor(context, zmq::socket_type::pair);
  monitor.connect(endpoint);
  return monitor;
}

std::vector<uint16_t> TakeEvents(zmq::socket_t& monitor) {
  std::vector<uint16_t> ids;
  while (true) {
    const std::vector<std::string> event = ReadFrames(monitor);  // the id and value, then the endpoint
    if (event.empty()) break;
    if (event[0].size() < 2) continue;
    uint16_t id;
    std::memcpy(&id, event[0].data(), 2);
    ids.push_back(id);
  }
  return ids;
}

void ZapGate::Describe(const std::string& refusal) {
  if (described_.insert(refusal).second) refusals_.push_back(refusal);
}

std::vector<std::string> ZapGate::TakeRefusals() {
  std::vector<std::string> refusals;
  refusals.swap(refusals_);
  return refusals;
}

CurveKeys RunCurveKeys(const std::string& secret) {
  if (secret.size() != 64 || secret.find_first_not_of("0123456789abcdef") != std::string::npos) {
    throw std::invalid_argument("the run's secret is not 64 hex digits");
  }
  uint8_t server_secret[32], client_secret[32], observer_secret[32];
  for (size_t i = 0; i < 32; ++i) {
    server_secret[i] = static_cast<uint8_t>(std::stoi(secret.substr(2 * i, 2), nullptr, 16));
    // other keys from the same random bytes: uniform still, and unknown without the secret
    client_secret[i] = server_secret[i] ^ 0x5c;
    observer_secret[i] = server_secret[i] ^ 0x36;
  }
  CurveKeys keys;
  keys.server_secret = Z85(server_secret);
  keys.client_secret = Z85(client_secret);
  keys.observer_secret = Z85(observer_secret);
  keys.server_public = PublicKey(keys.server_secret, nullptr);
  keys.client_public = PublicKey(keys.client_secret, &keys.client_public_raw);
  keys.observer_public = PublicKey(keys.observer_secret, &keys.observer_public_raw);
  return keys;
}

}  // namespace iapsim::bridge::internal
