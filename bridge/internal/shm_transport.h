#pragma once
// The bus's same-host transport (internal: only bus.cc includes it). Endpoints "shm://NAME".
//
// Every (publisher, subscriber) pair shares a queue of variable-length records in memory (memfd), written by
// the publisher and read by the subscriber without a system call. A unix seqpacket socket per pair, found
// under the abstract name of the publisher's endpoint, carries what memory cannot: the file descriptors of
// the queue (SCM_RIGHTS), a one-byte wake-up for a subscriber that went to sleep, and the hang-up when either
// side exits (nothing is left in the file system, even after kill -9).
//
// Who may connect: both ends check that the other runs as the same user (SO_PEERCRED), and a subscriber's
// first message is the run's secret (bridge/run_secret.h); a publisher hands its queue only to a subscriber
// that sent it. Every refusal is counted and described with the peer's pid and uid.
//
// Why not ZeroMQ for this: a ZeroMQ message between processes passes two I/O threads, three thread wake-ups
// of ~25 us each on a VM; here a sleeping subscriber costs one wake-up and a spinning one none. Why our own
// queue: Boost.Interprocess maps shared memory but has no single-writer record queue with hang-up detection
// and wake-ups a poll() can wait on; iceoryx needs one RouDi daemon per host shared by every run, which
// concurrent runs and test suites would have to coordinate.

#include <poll.h>
#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace iapsim::bridge::internal {

using SteadyClock = std::chrono::steady_clock;

inline constexpr char kShmScheme[] = "shm://";
bool IsShmEndpoint(const std::string& endpoint);

/// Bytes to write as one record: the record is the concatenation of the parts.
struct ByteSpan {
  const void* data;
  size_t size;
};

/// Single-writer single-reader queue of records in one memfd mapping. Positions only grow; a record that
/// would straddle the end is preceded by padding. Room for a "moved" marker is always kept, so the writer
/// can hand the stream over to a bigger queue at any time.
class ShmQueue {
 public:
  static std::unique_ptr<ShmQueue> Create(size_t capacity_bytes);  // writer
  static std::unique_ptr<ShmQueue> Open(int fd);                   // reader; takes the descriptor
  ~ShmQueue();
  ShmQueue(const ShmQueue&) = delete;
  ShmQueue& operator=(const ShmQueue&) = delete;

  int fd() const { return fd_; }
  size_t capacity() const { return capacity_; }
  /// The largest record body this queue can ever take.
  size_t MaxRecordBytes() const { return MaxRecordBytesAt(capacity_); }
  static size_t MaxRecordBytesAt(size_t capacity_bytes);

  /// Writer: false when there is no room now.
  bool TryWrite(const ByteSpan* parts, int count);
  /// Writer: the stream continues in the next queue sent over the socket.
  void WriteMoved();

  enum class Next { kEmpty, kRecord, kMoved };
  /// Reader: the next record stays valid until Pop().
  Next Peek(const uint8_t** data, size_t* size);
  void Pop();
  bool HasData() const;

 private:
  struct Header;
  ShmQueue(int fd, void* mapping, size_t capacity);

  int fd_;
  Header* header_;
  uint8_t* data_;
  size_t capacity_;
  uint64_t peeked_end_ = 0;
};

/// What a connection shares besides its queue, for its whole life (queues are replaced when they grow):
/// whether the subscriber sleeps, its name, and the topic prefixes it subscribed to (a seqlock-guarded table
/// the publisher filters with).
class ShmConnectionPage {
 public:
  static std::unique_ptr<ShmConnectionPage> Create();
  static std::unique_ptr<ShmConnectionPage> Open(int fd);
  ~ShmConnectionPage();
  ShmConnectionPage(const ShmConnectionPage&) = delete;
  ShmConnectionPage& operator=(const ShmConnectionPage&) = delete;
  int fd() const { return fd_; }

  // subscriber
  void WriteSubscriber(const std::string& node, const std::vector<std::string>& prefixes);
  void SetSleeping(bool sleeping);
  // publisher
  /// Re-reads the table when it changed; true when `prefixes` was updated.
  bool ReadSubscriptions(std::vector<std::string>* prefixes, std::string* node);
  /// True (and clears the flag) if the subscriber sleeps and needs a wake-up.
  bool TakeSleeping();

 private:
  struct Page;
  ShmConnectionPage(int fd, Page* page);
  int fd_;
  Page* page_;
  uint32_t seen_version_ = 0;
};

/// The publisher end: listens for subscribers, writes each record into the queue of every subscriber whose
/// prefixes match its topic.
class ShmPublisher {
 public:
  struct Options {
    std::string endpoint;  // shm://NAME
    size_t initial_queue_bytes = 64 << 10;
    size_t max_queue_bytes = 64 << 20;
    std::string secret;  // what a subscriber must send first
    // subscribers (node names) a blocking Publish waits for; any other is best effort, and is dropped (its
    // connection closed) when its queue stays full. Empty: every subscriber is waited for.
    std::vector<std::string> members;
  };
  explicit ShmPublisher(const Options& options);  // throws std::runtime_error if the name is taken
  ~ShmPublisher();

  int listen_fd() const { return listen_fd_; }
  /// Takes new subscribers and lets go of those that hung up (a few system calls: call now and then).
  void Accept();

  /// `topic` ends in '\0' (so "/a" does not match "/ab"). Queues grow up to max_queue_bytes; when one is
  /// still full: block = wait for room up to `block_timeout`; otherwise that subscriber alone misses the
  /// record. True when the record went to every subscriber it had to. Throws if the record is larger than the
  /// largest queue can take. `flags`, a byte of the record, gets `resync` for a subscriber that missed the
  /// topic's messages since its last one because it was muted (SetMuted), and is restored after.
  bool Publish(std::string_view topic, const ByteSpan* parts, int count, bool block,
               std::chrono::milliseconds block_timeout, char* flags, char resync);
  /// After a blocking Publish returned false: the subscribers whose queues stayed full, quoted.
  const std::string& stalled() const { return stalled_; }
  /// Subscribers (by node name) that get nothing until the next call, whatever they subscribed to; the next
  /// record of a topic they get says they missed its earlier ones on purpose (see Publish's `flags`).
  void SetMuted(const std::vector<std::string>& subscribers) { muted_ = subscribers; }
  /// Connections refused (another user, no or another secret) and subscribers dropped (not members, not
  /// reading) since the last call, one line each.
  std::vector<std::string> TakeEvents();
  uint64_t refused() const { return refused_; }
  uint64_t dropped_subscribers() const { return dropped_subscribers_; }

 private:
  struct Link {
    int fd = -1;
    pid_t pid = 0;
    std::unique_ptr<ShmConnectionPage> page;
    std::unique_ptr<ShmQueue> queue;
    std::vector<std::string> prefixes;
    std::string subscriber;
    bool dead = false;
    std::vector<std::string> muted_topics;  // it missed messages of these while muted: the next says so
  };
  struct Pending {  // accepted, its secret not read yet
    int fd;
    pid_t pid;
    SteadyClock::time_point deadline;
  };
  void Authenticate();
  void Refuse(int fd, pid_t pid, const std::string& why);
  bool IsMember(const Link& link) const;
  void Drop(Link& link);
  void MarkHungUp();
  bool Wants(Link& link, std::string_view topic);
  bool Muted(const Link& link) const;
  bool WriteTo(Link& link, std::string_view topic, const ByteSpan* parts, int count, char* flags,
               char resync);
  void Grow(Link& link, size_t record_bytes);
  void Wake(Link& link);

  Options options_;
  int listen_fd_ = -1;
  std::vector<Link> links_;
  std::vector<Link*> targets_;
  std::vector<char> written_;  // per target of a blocking Publish; storage reused
  std::vector<pollfd> poll_fds_;
  std::string stalled_;
  std::vector<std::string> muted_;
  std::vector<Pending> pending_;
  std::vector<std::string> events_;
  std::vector<pid_t> refused_pids_;
  uint64_t refused_ = 0, dropped_subscribers_ = 0;
};

/// The subscriber end: one connection per publisher endpoint, (re)connected as publishers come and go.
class ShmSubscriber {
 public:
  ShmSubscriber(const std::string& node, const std::vector<std::string>& endpoints,
                const std::string& secret);
  ~ShmSubscriber();

  void SetSubscriptions(const std::vector<std::string>& prefixes);
  /// Connects to publishers not connected yet (retrying every 10 ms) and reads what the sockets carry.
  void Maintain();
  /// Publishers refused (another user) since the last call, one line each.
  std::vector<std::string> TakeEvents();
  uint64_t refused() const { return refused_; }
  /// Calls `record(data, size)` for queued records, at most `max_records`; returns how many.
  int Drain(int max_records, const std::function<void(const uint8_t*, size_t)>& record);
  bool HasData() const;

  /// Before poll(): marks every connection asleep (unless `announce` is false: then publishers never wake
  /// it, and the caller polls its queues by the clock), appends the sockets to watch; false (and nothing
  /// marked) if a record arrived meanwhile.
  bool PrepareSleep(std::vector<pollfd>* fds, bool announce = true);
  void WakeUp();

 private:
  struct Link {
    std::string endpoint;
    int fd = -1;
    std::unique_ptr<ShmConnectionPage> page;
    std::unique_ptr<ShmQueue> queue;
    std::deque<int> next_queue_fds;
    bool hung_up = false;
    bool refusal_described = false;  // it was refused, and the log said so once
    SteadyClock::time_point next_attempt{};
  };
  void Connect(Link& link);
  void ReadSocket(Link& link);
  void Close(Link& link);

  std::string node_;
  std::string secret_;
  std::vector<Link> links_;
  std::vector<std::string> prefixes_;
  std::vector<std::string> events_;
  uint64_t refused_ = 0;
};

}  // namespace iapsim::bridge::internal
