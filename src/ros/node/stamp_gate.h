#pragma once
// Which input messages may reach the synchronizer, and when the input stamps
// have moved to another timeline (a looping bag, a restarted driver, a reset
// simulation clock) so that the synchronizer must start over.
//
// ROS-free (stamps are signed nanoseconds, time is passed in), so a fuzz
// target drives it with arbitrary stamps and a test with arbitrary clocks.
//
// Why each rule:
//  - ros::Duration and message_filters compute in signed 32-bit seconds and
//    abort the process when a result leaves that range. A stamp at or past
//    2^31 s (2038; an uninitialised driver stamp such as sec = 2^32 - 1) never
//    passes, and a stamp more than kMaxSkew from the newest admitted one is
//    off the timeline: it reaches the synchronizer only through a jump, which
//    rebuilds it empty. So the synchronizer only ever compares stamps of one
//    timeline, far inside the range.
//  - One stamp off the timeline (a glitch) is held, not obeyed: a jump is
//    confirmed only when a second message, on any input, lands near it. A
//    glitch then costs its own message, never a reset.
//  - A small step back on one input (driver jitter) drops that one message:
//    the synchronizer expects each input in order, and a reset for it would
//    throw away every pending message of the other inputs.
//  - After a confirmed jump, the other inputs' messages from before it (still
//    arriving on their own connections) are told apart by being nearer the
//    old timeline than the new one, and dropped; an input's first message
//    nearer the new timeline moves it over. No fixed black-out.

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>

namespace relocalizer_ros {

// Nanoseconds since the epoch of a ROS stamp (sec, nsec): exact, and any
// difference of two of them fits in int64.
int64_t stampNanoseconds(uint32_t sec, uint32_t nsec);

class StampGate {
 public:
  static constexpr int kInputs = 3;
  using Clock = std::chrono::steady_clock;

  // Stamps at or past 2^31 s break ros::Duration arithmetic (and mean 2038).
  static constexpr int64_t kMaxStampNs = (int64_t{1} << 31) * 1'000'000'000;
  // A step back on one input shorter than this is jitter (that message is
  // dropped); longer, a jump. Bags loop after seconds, drivers jitter by a
  // frame or two (at most ~100 ms at 15-30 Hz).
  static constexpr int64_t kMinJumpNs = 500'000'000;
  // Inputs of one camera are stamped within a frame or two of each other;
  // stamps further than an hour from the newest admitted one are another
  // timeline (or a broken clock), whatever their direction.
  static constexpr int64_t kMaxSkewNs = int64_t{3600} * 1'000'000'000;
  // A second message within this of a held off-timeline stamp confirms the
  // jump: consecutive frames of one camera are well within it.
  static constexpr int64_t kConfirmNs = int64_t{2} * 1'000'000'000;
  // How long a held stamp waits for its confirmation, and how long the other
  // inputs may take to follow a jump (wall time).
  static constexpr std::chrono::seconds kWindow{5};

  enum class Drop {
    None,
    BeyondRange,  // stamp at or past 2^31 s
    OutOfOrder,   // a small step back on its own input
    OldTimeline,  // sent before a jump that its input has not followed yet
    Unconfirmed,  // held off the timeline, and no other message followed it there
  };

  struct Jump {
    int input = 0;        // whose stamp opened it
    int64_t from_ns = 0;  // newest admitted stamp before the jump
    int64_t to_ns = 0;    // the new timeline's first stamp
  };

  struct Decision {
    // The message goes to the synchronizer (after the held one, if released).
    bool admit = false;
    // The message is kept aside as a possible new timeline: the caller keeps
    // it until a later decision releases or discards it.
    bool hold = false;
    Drop drop = Drop::None;
    // The previously held message was a glitch (expired, or replaced by a
    // message of another timeline): the caller drops it.
    bool discard_held = false;
    // A confirmed jump: the caller rebuilds the synchronizer, then adds the
    // held message, then this one if `admit`.
    std::optional<Jump> jump;
  };

  Decision classify(int input, int64_t stamp_ns, Clock::time_point now);

  // Stamps currently held (for the fuzz target's invariants).
  bool holding() const { return held_.has_value(); }

 private:
  struct Held {
    int input;
    int64_t stamp_ns;
    Clock::time_point since;
  };
  bool offTimeline(int input, int64_t stamp_ns) const;
  void place(int input, int64_t stamp_ns, Clock::time_point now, Decision& decision);
  void confirmJump(Clock::time_point now, Decision& decision);
  void admit(int input, int64_t stamp_ns);
  void expire(Clock::time_point now, Decision& decision);

  std::optional<int64_t> newest_;                       // newest admitted stamp, any input
  std::array<std::optional<int64_t>, kInputs> last_{};  // newest admitted stamp per input
  std::optional<Held> held_;
  // An open jump: the inputs that have not followed it yet, and the two
  // timelines' stamps that tell their messages apart.
  std::array<bool, kInputs> behind_{};
  bool jump_open_ = false;
  int64_t old_newest_ = 0;
  int64_t new_first_ = 0;
  Clock::time_point jump_since_;
};

}  // namespace relocalizer_ros
