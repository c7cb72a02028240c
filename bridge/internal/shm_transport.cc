#include "bridge/internal/shm_transport.h"

#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <thread>

#include "bridge/run_secret.h"

namespace iapsim::bridge::internal {
namespace {

constexpr uint32_t kQueueMagic = 0x51534149;  // "IASQ"
constexpr uint32_t kPageMagic = 0x50534149;   // "IASP"
constexpr size_t kHeaderBytes = 4096;         // the queue's data starts on its own page
constexpr auto kReconnectPeriod = std::chrono::milliseconds(10);
// a subscriber's first message: this kind, then the run's secret
constexpr char kSecretKind = 'A';
// an accepted connection that has not sent it by then is refused
constexpr auto kAuthenticationTimeout = std::chrono::seconds(2);
// after refusing a publisher of another user, try that endpoint again this much later
constexpr auto kRefusedRetryPeriod = std::chrono::seconds(1);

// record header: body size and kind; bodies are padded to 8 bytes
struct RecordHeader {
  uint32_t size;
  uint32_t kind;
};
enum RecordKind : uint32_t { kRecord = 1, kPadding = 2, kMoved = 3 };
constexpr size_t kRecordHeaderBytes = sizeof(RecordHeader);
static_assert(kRecordHeaderBytes == 8);

size_t Align8(size_t n) { return (n + 7) & ~size_t{7}; }

static_assert(std::atomic<uint64_t>::is_always_lock_free && std::atomic<uint32_t>::is_always_lock_free,
              "shared-memory atomics must be lock-free to work across processes");

std::runtime_error SystemError(const std::string& what) {
  return std::runtime_error(what + ": " + std::strerror(errno));
}

int CreateMemory(const char* name, size_t bytes) {
  const int fd = memfd_create(name, MFD_CLOEXEC);
  if (fd < 0) throw SystemError("memfd_create");
  if (ftruncate(fd, static_cast<off_t>(bytes)) != 0) {
    close(fd);
    throw SystemError("ftruncate of shared memory");
  }
  return fd;
}

void* MapMemory(int fd, size_t bytes) {
  void* p = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  if (p == MAP_FAILED) throw SystemError("mmap of shared memory");
  return p;
}

size_t MemorySize(int fd) {
  struct stat st {};
  if (fstat(fd, &st) != 0) throw SystemError("fstat of shared memory");
  return static_cast<size_t>(st.st_size);
}

// shm://NAME -> the abstract unix socket "iapsim-shm:NAME"
sockaddr_un SocketAddress(const std::string& endpoint, socklen_t* length) {
  const std::string name = "iapsim-shm:" + endpoint.substr(std::strlen(kShmScheme));
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (endpoint.size() <= std::strlen(kShmScheme) || name.size() + 1 > sizeof(address.sun_path)) {
    throw std::runtime_error("bad shared-memory endpoint '" + endpoint +
                             "' (expected shm://NAME, NAME of 1 to " +
                             std::to_string(sizeof(address.sun_path) - 12) + " characters)");
  }
  std::memcpy(address.sun_path + 1, name.data(), name.size());  // sun_path[0] = 0: abstract namespace
  *length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + name.size());
  return address;
}

// socket messages, publisher -> subscriber: 'C' + page and queue fds, 'Q' + next queue fd, 'B' wake-up
bool SendWithFds(int socket, char kind, const std::vector<int>& fds) {
  msghdr message{};
  iovec payload{&kind, 1};
  message.msg_iov = &payload;
  message.msg_iovlen = 1;
  alignas(cmsghdr) char control[CMSG_SPACE(2 * sizeof(int))];
  if (!fds.empty()) {
    message.msg_control = control;
    message.msg_controllen = CMSG_SPACE(fds.size() * sizeof(int));
    cmsghdr* header = CMSG_FIRSTHDR(&message);
    header->cmsg_level = SOL_SOCKET;
    header->cmsg_type = SCM_RIGHTS;
    header->cmsg_len = CMSG_LEN(fds.size() * sizeof(int));
    std::memcpy(CMSG_DATA(header), fds.data(), fds.size() * sizeof(int));
  }
  return sendmsg(socket, &message, MSG_DONTWAIT | MSG_NOSIGNAL) == 1;
}

// returns the message kind, 0 when the peer hung up, -1 when nothing is queued
int ReceiveWithFds(int socket, std::vector<int>* fds) {
  char kind = 0;
  iovec payload{&kind, 1};
  msghdr message{};
  message.msg_iov = &payload;
  message.msg_iovlen = 1;
  alignas(cmsghdr) char control[CMSG_SPACE(4 * sizeof(int))];
  message.msg_control = control;
  message.msg_controllen = sizeof(control);
  const ssize_t n = recvmsg(socket, &message, MSG_DONTWAIT | MSG_CMSG_CLOEXEC);
  if (n == 0) return 0;
  if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR ? -1 : 0;
  fds->clear();
  for (cmsghdr* h = CMSG_FIRSTHDR(&message); h != nullptr; h = CMSG_NXTHDR(&message, h)) {
    if (h->cmsg_level != SOL_SOCKET || h->cmsg_type != SCM_RIGHTS) continue;
    const size_t count = (h->cmsg_len - CMSG_LEN(0)) / sizeof(int);
    for (size_t i = 0; i < count; ++i) {
      int fd;
      std::memcpy(&fd, CMSG_DATA(h) + i * sizeof(int), sizeof(int));
      fds->push_back(fd);
    }
  }
  return static_cast<unsigned char>(kind);
}

}  // namespace

bool IsShmEndpoint(const std::string& endpoint) { return endpoint.rfind(kShmScheme, 0) == 0; }

// ---------------------------------------------------------------------------------------------- ShmQueue

struct ShmQueue::Header {
  uint32_t magic;
  uint32_t reserved;
  uint64_t capacity;
  alignas(64) std::atomic<uint64_t> write_position;  // written by the writer only
  alignas(64) std::atomic<uint64_t> read_position;   // written by the reader only
};

ShmQueue::ShmQueue(int fd, void* mapping, size_t capacity)
    : fd_(fd),
      header_(static_cast<Header*>(mapping)),
      data_(static_cast<uint8_t*>(mapping) + kHeaderBytes),
      capacity_(capacity) {}

std::unique_ptr<ShmQueue> ShmQueue::Create(size_t capacity_bytes) {
  static_assert(sizeof(Header) <= kHeaderBytes);
  const size_t capacity = Align8(capacity_bytes);
  const int fd = CreateMemory("iapsim-bus-queue", kHeaderBytes + capacity);
  void* mapping = MapMemory(fd, kHeaderBytes + capacity);
  auto* header = new (mapping) Header{};
  header->magic = kQueueMagic;
  header->capacity = capacity;
  return std::unique_ptr<ShmQueue>(new ShmQueue(fd, mapping, capacity));
}

std::unique_ptr<ShmQueue> ShmQueue::Open(int fd) {
  size_t bytes;
  try {
    bytes = MemorySize(fd);
  } catch (...) {
    close(fd);
    throw;
  }
  if (bytes <= kHeaderBytes) {
    close(fd);
    throw std::runtime_error("shared-memory queue: " + std::to_string(bytes) + " bytes is not a queue");
  }
  void* mapping = MapMemory(fd, bytes);
  const auto* header = static_cast<const Header*>(mapping);
  if (header->magic != kQueueMagic || header->capacity != bytes - kHeaderBytes || header->capacity % 8 != 0) {
    munmap(mapping, bytes);
    close(fd);
    throw std::runtime_error("shared-memory queue: bad header");
  }
  return std::unique_ptr<ShmQueue>(new ShmQueue(fd, mapping, bytes - kHeaderBytes));
}

ShmQueue::~ShmQueue() {
  munmap(header_, kHeaderBytes + capacity_);
  close(fd_);
}

size_t ShmQueue::MaxRecordBytesAt(size_t capacity_bytes) {
  // worst case: padding to the end just short of a whole record, then the record, then the moved marker
  return (Align8(capacity_bytes) - kRecordHeaderBytes) / 2 - kRecordHeaderBytes;
}

bool ShmQueue::TryWrite(const ByteSpan* parts, int count) {
  size_t body = 0;
  for (int i = 0; i < count; ++i) body += parts[i].size;
  if (body > MaxRecordBytes()) return false;
  const size_t need = kRecordHeaderBytes + Align8(body);
  uint64_t write = header_->write_position.load(std::memory_order_relaxed);
  const uint64_t read = header_->read_position.load(std::memory_order_acquire);
  const size_t free = capacity_ - static_cast<size_t>(write - read);
  size_t offset = static_cast<size_t>(write % capacity_);
  const size_t rest = capacity_ - offset;
  const size_t total = need <= rest ? need : rest + need;
  if (total + kRecordHeaderBytes > free) return false;  // keep room for a moved marker
  if (need > rest) {
    const RecordHeader padding{static_cast<uint32_t>(rest - kRecordHeaderBytes), kPadding};
    std::memcpy(data_ + offset, &padding, kRecordHeaderBytes);
    write += rest;
    offset = 0;
  }
  const RecordHeader header{static_cast<uint32_t>(body), kRecord};
  std::memcpy(data_ + offset, &header, kRecordHeaderBytes);
  uint8_t* out = data_ + offset + kRecordHeaderBytes;
  for (int i = 0; i < count; ++i) {
    std::memcpy(out, parts[i].data, parts[i].size);
    out += parts[i].size;
  }
  header_->write_position.store(write + need, std::memory_order_release);
  return true;
}

void ShmQueue::WriteMoved() {
  const uint64_t write = header_->write_position.load(std::memory_order_relaxed);
  const RecordHeader moved{0, kMoved};
  // offsets are multiples of 8 below the capacity, so a header always fits before the end
  std::memcpy(data_ + write % capacity_, &moved, kRecordHeaderBytes);
  header_->write_position.store(write + kRecordHeaderBytes, std::memory_order_release);
}

ShmQueue::Next ShmQueue::Peek(const uint8_t** data, size_t* size) {
  uint64_t read = header_->read_position.load(std::memory_order_relaxed);
  const uint64_t write = header_->write_position.load(std::memory_order_acquire);
  while (read != write) {
    const size_t offset = static_cast<size_t>(read % capacity_);
    RecordHeader header;
    std::memcpy(&header, data_ + offset, kRecordHeaderBytes);
    const size_t span = kRecordHeaderBytes + Align8(header.size);
    if (span > write - read || offset + span > capacity_ ||
        (header.kind != kRecord && header.kind != kPadding && header.kind != kMoved)) {
      throw std::runtime_error("shared-memory queue: corrupt record at position " + std::to_string(read));
    }
    if (header.kind == kPadding) {
      read += span;
      header_->read_position.store(read, std::memory_order_release);
      continue;
    }
    if (header.kind == kMoved) return Next::kMoved;
    *data = data_ + offset + kRecordHeaderBytes;
    *size = header.size;
    peeked_end_ = read + span;
    return Next::kRecord;
  }
  return Next::kEmpty;
}

void ShmQueue::Pop() { header_->read_position.store(peeked_end_, std::memory_order_release); }

bool ShmQueue::HasData() const {
  return header_->read_position.load(std::memory_order_relaxed) !=
         header_->write_position.load(std::memory_order_acquire);
}

// ------------------------------------------------------------------------------------- ShmConnectionPage

struct ShmConnectionPage::Page {
  uint32_t magic;
  std::atomic<uint32_t> sleeping;
  std::atomic<uint32_t> version;  // seqlock: odd while the subscriber writes the table
  uint32_t table_bytes;           // 0xffffffff: the table overflowed, send everything
  char node[64];
  uint8_t table[4096 - 80];  // entries: u16 length + prefix bytes (prefixes may contain '\0')
};
constexpr uint32_t kTableOverflow = 0xffffffff;

ShmConnectionPage::ShmConnectionPage(int fd, Page* page) : fd_(fd), page_(page) {}

std::unique_ptr<ShmConnectionPage> ShmConnectionPage::Create() {
  static_assert(sizeof(Page) == 4096);
  const int fd = CreateMemory("iapsim-bus-connection", sizeof(Page));
  auto* page = new (MapMemory(fd, sizeof(Page))) Page{};
  page->magic = kPageMagic;
  return std::unique_ptr<ShmConnectionPage>(new ShmConnectionPage(fd, page));
}

std::unique_ptr<ShmConnectionPage> ShmConnectionPage::Open(int fd) {
  if (MemorySize(fd) != sizeof(Page)) {
    close(fd);
    throw std::runtime_error("shared-memory connection: bad page size");
  }
  auto* page = static_cast<Page*>(MapMemory(fd, sizeof(Page)));
  if (page->magic != kPageMagic) {
    munmap(page, sizeof(Page));
    close(fd);
    throw std::runtime_error("shared-memory connection: bad page");
  }
  return std::unique_ptr<ShmConnectionPage>(new ShmConnectionPage(fd, page));
}

ShmConnectionPage::~ShmConnectionPage() {
  munmap(page_, sizeof(Page));
  close(fd_);
}

void ShmConnectionPage::WriteSubscriber(const std::string& node, const std::vector<std::string>& prefixes) {
  const uint32_t version = page_->version.load(std::memory_order_relaxed);
  page_->version.store(version + 1, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);
  std::memset(page_->node, 0, sizeof(page_->node));
  std::memcpy(page_->node, node.data(), std::min(node.size(), sizeof(page_->node) - 1));
  size_t used = 0;
  bool overflow = false;
  for (const auto& prefix : prefixes) {
    if (used + 2 + prefix.size() > sizeof(page_->table) || prefix.size() > 0xffff) {
      overflow = true;
      break;
    }
    const uint16_t n = static_cast<uint16_t>(prefix.size());
    std::memcpy(page_->table + used, &n, 2);
    std::memcpy(page_->table + used + 2, prefix.data(), n);
    used += 2 + n;
  }
  page_->table_bytes = overflow ? kTableOverflow : static_cast<uint32_t>(used);
  page_->version.store(version + 2, std::memory_order_release);
}

bool ShmConnectionPage::ReadSubscriptions(std::vector<std::string>* prefixes, std::string* node) {
  const uint32_t before = page_->version.load(std::memory_order_acquire);
  if (before == seen_version_ || before % 2 == 1) return false;
  uint32_t table_bytes = page_->table_bytes;
  uint8_t table[sizeof(page_->table)];
  char name[sizeof(page_->node)];
  std::memcpy(name, page_->node, sizeof(name));
  std::memcpy(table, page_->table, std::min<size_t>(table_bytes, sizeof(table)));
  std::atomic_thread_fence(std::memory_order_acquire);
  if (page_->version.load(std::memory_order_relaxed) != before) return false;  // written meanwhile: later
  seen_version_ = before;
  name[sizeof(name) - 1] = '\0';
  *node = name;
  prefixes->clear();
  if (table_bytes == kTableOverflow) {
    prefixes->push_back("");  // the subscriber filters what it receives anyway
    return true;
  }
  for (size_t used = 0; used + 2 <= table_bytes;) {
    uint16_t n;
    std::memcpy(&n, table + used, 2);
    if (used + 2 + n > table_bytes) break;
    prefixes->emplace_back(reinterpret_cast<const char*>(table + used + 2), n);
    used += 2 + n;
  }
  return true;
}

void ShmConnectionPage::SetSleeping(bool sleeping) {
  page_->sleeping.store(sleeping ? 1 : 0, std::memory_order_seq_cst);
}

bool ShmConnectionPage::TakeSleeping() {
  // pairs with the subscriber's store of `sleeping` then load of the queue position (both seq_cst): one of
  // the two sides sees the other, so a record is never left unannounced to a sleeper
  std::atomic_thread_fence(std::memory_order_seq_cst);
  return page_->sleeping.load(std::memory_order_relaxed) != 0 && page_->sleeping.exchange(0) != 0;
}

// ------------------------------------------------------------------------------------------ ShmPublisher

ShmPublisher::ShmPublisher(const Options& options) : options_(options) {
  socklen_t length;
  const sockaddr_un address = SocketAddress(options.endpoint, &length);
  listen_fd_ = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) throw SystemError("socket");
  if (bind(listen_fd_, reinterpret_cast<const sockaddr*>(&address), length) != 0 ||
      listen(listen_fd_, 64) != 0) {
    const std::runtime_error error = SystemError("cannot listen");
    close(listen_fd_);
    throw error;
  }
}

ShmPublisher::~ShmPublisher() {
  for (auto& link : links_) close(link.fd);
  for (const Pending& p : pending_) close(p.fd);
  close(listen_fd_);
}

void ShmPublisher::Accept() {
  while (true) {
    const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) break;
    ucred peer{};
    socklen_t size = sizeof(peer);
    if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &peer, &size) != 0) {
      close(fd);
      continue;
    }
    if (peer.uid != getuid()) {
      Refuse(fd, peer.pid, "runs as another user (uid " + std::to_string(peer.uid) + ")");
      continue;
    }
    pending_.push_back({fd, peer.pid, SteadyClock::now() + kAuthenticationTimeout});
  }
  Authenticate();
  MarkHungUp();
  for (auto& link : links_) {
    if (link.dead) close(link.fd);
  }
  links_.erase(std::remove_if(links_.begin(), links_.end(), [](const Link& l) { return l.dead; }),
               links_.end());
}

// Reads the first message of each accepted connection: the run's secret gets the connection its queue.
void ShmPublisher::Authenticate() {
  const auto now = SteadyClock::now();
  for (size_t i = 0; i < pending_.size();) {
    const Pending p = pending_[i];
    char message[128];
    const ssize_t n = recv(p.fd, message, sizeof(message), MSG_DONTWAIT);
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      if (now < p.deadline) {
        ++i;
        continue;
      }
      Refuse(p.fd, p.pid, "sent no secret within 2 s");
    } else if (n <= 0) {
      close(p.fd);  // gone before it said anything
    } else if (message[0] != kSecretKind ||
               !SameSecret(std::string(message + 1, static_cast<size_t>(n - 1)), options_.secret)) {
      Refuse(p.fd, p.pid, "did not send the run's secret");
    } else {
      Link link;
      link.fd = p.fd;
      link.pid = p.pid;
      link.page = ShmConnectionPage::Create();
      link.queue = ShmQueue::Create(options_.initial_queue_bytes);
      if (SendWithFds(p.fd, 'C', {link.page->fd(), link.queue->fd()})) {
        links_.push_back(std::move(link));
      } else {
        close(p.fd);
      }
    }
    pending_.erase(pending_.begin() + static_cast<std::ptrdiff_t>(i));
  }
}

void ShmPublisher::Refuse(int fd, pid_t pid, const std::string& why) {
  close(fd);
  ++refused_;
  // a refused subscriber may try again every few milliseconds: each process is described once
  if (std::find(refused_pids_.begin(), refused_pids_.end(), pid) != refused_pids_.end()) return;
  refused_pids_.push_back(pid);
  events_.push_back("refused a subscriber (pid " + std::to_string(pid) + ") that " + why);
}

bool ShmPublisher::IsMember(const Link& link) const {
  return options_.members.empty() || std::find(options_.members.begin(), options_.members.end(),
                                               link.subscriber) != options_.members.end();
}

// A subscriber that is not a process of the run and does not keep up is let go, never waited for.
void ShmPublisher::Drop(Link& link) {
  link.dead = true;
  ++dropped_subscribers_;
  events_.push_back("dropped subscriber '" + link.subscriber + "' (pid " + std::to_string(link.pid) +
                    "): not a process of the run, and its queue stayed full at " +
                    std::to_string(link.queue->capacity() >> 20) + " MiB");
}

std::vector<std::string> ShmPublisher::TakeEvents() {
  std::vector<std::string> events;
  events.swap(events_);
  return events;
}

void ShmPublisher::MarkHungUp() {
  // a subscriber never writes: a readable socket means it hung up
  poll_fds_.clear();
  for (const auto& link : links_) poll_fds_.push_back({link.fd, POLLIN, 0});
  if (!poll_fds_.empty() && poll(poll_fds_.data(), poll_fds_.size(), 0) > 0) {
    for (size_t i = 0; i < poll_fds_.size(); ++i) {
      if (poll_fds_[i].revents != 0) links_[i].dead = true;
    }
  }
}

bool ShmPublisher::Wants(Link& link, std::string_view topic) {
  link.page->ReadSubscriptions(&link.prefixes, &link.subscriber);
  for (const auto& prefix : link.prefixes) {
    if (topic.compare(0, prefix.size(), prefix) != 0) continue;
    if (!Muted(link)) return true;
    if (std::find(link.muted_topics.begin(), link.muted_topics.end(), topic) == link.muted_topics.end()) {
      link.muted_topics.emplace_back(topic);
    }
    return false;
  }
  return false;
}

void ShmPublisher::Grow(Link& link, size_t record_bytes) {
  size_t capacity = link.queue->capacity() * 2;
  while (capacity < 2 * (record_bytes + 3 * kRecordHeaderBytes)) capacity *= 2;
  auto next = ShmQueue::Create(std::min(capacity, options_.max_queue_bytes));
  // the descriptor goes first: when the subscriber reads the marker, the socket already holds it
  if (!SendWithFds(link.fd, 'Q', {next->fd()})) {
    link.dead = true;
    return;
  }
  link.queue->WriteMoved();
  link.queue = std::move(next);
  Wake(link);
}

bool ShmPublisher::Muted(const Link& link) const {
  return std::find(muted_.begin(), muted_.end(), link.subscriber) != muted_.end();
}

// the record into the link's queue, flagged when the link missed the topic's earlier messages while muted
bool ShmPublisher::WriteTo(Link& link, std::string_view topic, const ByteSpan* parts, int count, char* flags,
                           char resync) {
  const auto missed = std::find(link.muted_topics.begin(), link.muted_topics.end(), topic);
  if (missed == link.muted_topics.end()) return link.queue->TryWrite(parts, count);
  *flags |= resync;
  const bool written = link.queue->TryWrite(parts, count);
  *flags &= ~resync;
  if (written) link.muted_topics.erase(missed);
  return written;
}

bool ShmPublisher::Publish(std::string_view topic, const ByteSpan* parts, int count, bool block,
                           std::chrono::milliseconds block_timeout, char* flags, char resync) {
  size_t record_bytes = 0;
  for (int i = 0; i < count; ++i) record_bytes += parts[i].size;
  targets_.clear();
  for (auto& link : links_) {
    if (!link.dead && Wants(link, topic)) targets_.push_back(&link);
  }
  if (record_bytes > ShmQueue::MaxRecordBytesAt(options_.max_queue_bytes)) {
    throw std::runtime_error("a message of " + std::to_string(record_bytes) +
                             " bytes exceeds the largest shared-memory queue (" +
                             std::to_string(options_.max_queue_bytes >> 20) + " MiB)");
  }
  // a queue too small for the record grows
  for (Link* link : targets_) {
    while (!link->dead && link->queue->MaxRecordBytes() < record_bytes &&
           link->queue->capacity() < options_.max_queue_bytes) {
      Grow(*link, record_bytes);
    }
  }
  if (block) {
    // lossless: each target gets the record once it has room; those still full at the deadline miss it
    std::vector<char>& written = written_;
    written.assign(targets_.size(), 0);
    size_t remaining = targets_.size();
    std::optional<SteadyClock::time_point> deadline;  // read the clock only when a queue is full
    while (remaining > 0) {
      for (size_t i = 0; i < targets_.size(); ++i) {
        Link& link = *targets_[i];
        if (written[i]) continue;
        if (link.dead || WriteTo(link, topic, parts, count, flags, resync)) {
          written[i] = 1;
          --remaining;
          if (!link.dead) Wake(link);
        } else if (link.queue->capacity() < options_.max_queue_bytes) {
          Grow(link, record_bytes);
        } else if (!IsMember(link)) {
          Drop(link);
          written[i] = 1;
          --remaining;
        }
      }
      if (remaining == 0) break;
      if (!deadline) deadline = SteadyClock::now() + block_timeout;
      if (SteadyClock::now() > *deadline) {
        stalled_.clear();
        for (size_t i = 0; i < targets_.size(); ++i) {
          if (!written[i]) stalled_ += (stalled_.empty() ? "'" : ", '") + targets_[i]->subscriber + "'";
        }
        return false;
      }
      MarkHungUp();  // a subscriber that died while we wait for it (links_ must not change: targets_)
      std::this_thread::sleep_for(std::chrono::microseconds(20));
    }
    return true;
  }
  bool all = true;
  for (Link* link : targets_) {
    if (WriteTo(*link, topic, parts, count, flags, resync)) {
      Wake(*link);
      continue;
    }
    if (link->queue->capacity() < options_.max_queue_bytes) {
      Grow(*link, record_bytes);
      if (WriteTo(*link, topic, parts, count, flags, resync)) {
        Wake(*link);
        continue;
      }
    }
    if (!IsMember(*link)) {
      Drop(*link);
      continue;
    }
    all = false;  // best effort: this subscriber alone misses the record
  }
  return all;
}

void ShmPublisher::Wake(Link& link) {
  if (link.page->TakeSleeping()) SendWithFds(link.fd, 'B', {});
}

// ----------------------------------------------------------------------------------------- ShmSubscriber

ShmSubscriber::ShmSubscriber(const std::string& node, const std::vector<std::string>& endpoints,
                             const std::string& secret)
    : node_(node), secret_(secret) {
  for (const auto& endpoint : endpoints) {
    socklen_t length;
    (void)SocketAddress(endpoint, &length);  // validates the name now, not at the first connect
    links_.push_back(Link{});
    links_.back().endpoint = endpoint;
  }
}

ShmSubscriber::~ShmSubscriber() {
  for (auto& link : links_) Close(link);
}

void ShmSubscriber::SetSubscriptions(const std::vector<std::string>& prefixes) {
  prefixes_ = prefixes;
  for (auto& link : links_) {
    if (link.page) link.page->WriteSubscriber(node_, prefixes_);
  }
}

void ShmSubscriber::Connect(Link& link) {
  socklen_t length;
  const sockaddr_un address = SocketAddress(link.endpoint, &length);
  const int fd = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) throw SystemError("socket");
  if (connect(fd, reinterpret_cast<const sockaddr*>(&address), length) != 0) {
    close(fd);  // not listening yet (or any more): try again later
    link.next_attempt = SteadyClock::now() + kReconnectPeriod;
    return;
  }
  // the secret goes only to a publisher of this user
  ucred peer{};
  socklen_t size = sizeof(peer);
  if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &peer, &size) != 0 || peer.uid != getuid()) {
    close(fd);
    ++refused_;
    if (!link.refusal_described) {
      events_.push_back("refused publisher " + link.endpoint + " (pid " + std::to_string(peer.pid) +
                        "): it runs as another user (uid " + std::to_string(peer.uid) + ")");
      link.refusal_described = true;
    }
    link.next_attempt = SteadyClock::now() + kRefusedRetryPeriod;
    return;
  }
  const std::string message = kSecretKind + secret_;
  if (send(fd, message.data(), message.size(), MSG_DONTWAIT | MSG_NOSIGNAL) !=
      static_cast<ssize_t>(message.size())) {
    close(fd);
    link.next_attempt = SteadyClock::now() + kReconnectPeriod;
    return;
  }
  link.fd = fd;
}

std::vector<std::string> ShmSubscriber::TakeEvents() {
  std::vector<std::string> events;
  events.swap(events_);
  return events;
}

void ShmSubscriber::Close(Link& link) {
  for (const int fd : link.next_queue_fds) close(fd);
  link.next_queue_fds.clear();
  link.queue.reset();
  link.page.reset();
  if (link.fd >= 0) close(link.fd);
  link.fd = -1;
  link.hung_up = false;
  link.next_attempt = SteadyClock::now() + kReconnectPeriod;
}

void ShmSubscriber::ReadSocket(Link& link) {
  std::vector<int> fds;
  while (link.fd >= 0 && !link.hung_up) {
    const int kind = ReceiveWithFds(link.fd, &fds);
    if (kind < 0) return;
    if (kind == 0) {
      link.hung_up = true;  // the publisher exited: its queue is read to the end, then we reconnect
      if (!link.queue) Close(link);
      return;
    }
    if (kind == 'C' && fds.size() == 2 && !link.page) {
      link.page = ShmConnectionPage::Open(fds[0]);
      link.queue = ShmQueue::Open(fds[1]);
      link.page->WriteSubscriber(node_, prefixes_);
    } else if (kind == 'Q' && fds.size() == 1) {
      link.next_queue_fds.push_back(fds[0]);
    } else {
      for (const int fd : fds) close(fd);
    }
  }
}

void ShmSubscriber::Maintain() {
  const auto now = SteadyClock::now();
  for (auto& link : links_) {
    if (link.fd < 0 && now >= link.next_attempt) Connect(link);
    if (link.fd >= 0) ReadSocket(link);
  }
}

int ShmSubscriber::Drain(int max_records, const std::function<void(const uint8_t*, size_t)>& record) {
  int count = 0;
  for (auto& link : links_) {
    while (link.queue && count < max_records) {
      const uint8_t* data;
      size_t size;
      const ShmQueue::Next next = link.queue->Peek(&data, &size);
      if (next == ShmQueue::Next::kEmpty) {
        if (link.hung_up) Close(link);
        break;
      }
      if (next == ShmQueue::Next::kMoved) {
        if (link.next_queue_fds.empty()) ReadSocket(link);
        if (link.next_queue_fds.empty())
          throw std::runtime_error("shared-memory queue moved without a successor");
        link.queue = ShmQueue::Open(link.next_queue_fds.front());
        link.next_queue_fds.pop_front();
        continue;
      }
      // the record is released even if the callback throws (a type mismatch): it is never seen twice
      struct PopOnExit {
        ShmQueue& queue;
        ~PopOnExit() { queue.Pop(); }
      } pop{*link.queue};
      ++count;
      record(data, size);
    }
  }
  return count;
}

bool ShmSubscriber::HasData() const {
  for (const auto& link : links_) {
    if (link.queue && link.queue->HasData()) return true;
  }
  return false;
}

bool ShmSubscriber::PrepareSleep(std::vector<pollfd>* fds, bool announce) {
  for (auto& link : links_) {
    if (link.page && announce) link.page->SetSleeping(true);
  }
  std::atomic_thread_fence(std::memory_order_seq_cst);  // see TakeSleeping
  if (HasData()) {
    WakeUp();
    return false;
  }
  for (const auto& link : links_) {
    if (link.fd >= 0) fds->push_back({link.fd, POLLIN, 0});
  }
  return true;
}

void ShmSubscriber::WakeUp() {
  for (auto& link : links_) {
    if (link.page) link.page->SetSleeping(false);
  }
}

}  // namespace iapsim::bridge::internal
