#include "stamp_gate.h"

#include <cstdlib>

namespace relocalizer_ros {

namespace {

int64_t distance(int64_t a, int64_t b) { return a > b ? a - b : b - a; }

}  // namespace

int64_t stampNanoseconds(uint32_t sec, uint32_t nsec) {
  return static_cast<int64_t>(sec) * 1'000'000'000 + static_cast<int64_t>(nsec);
}

StampGate::Decision StampGate::classify(int input, int64_t stamp_ns, Clock::time_point now) {
  Decision decision;
  expire(now, decision);
  if (stamp_ns < 0 || stamp_ns >= kMaxStampNs) {
    decision.drop = Drop::BeyondRange;
    return decision;
  }
  place(input, stamp_ns, now, decision);
  return decision;
}

void StampGate::place(int input, int64_t stamp_ns, Clock::time_point now, Decision& decision) {
  if (jump_open_ && behind_[input]) {
    if (distance(stamp_ns, new_first_) >= distance(stamp_ns, old_newest_)) {
      decision.drop = Drop::OldTimeline;
      return;
    }
    behind_[input] = false;
    last_[input].reset();
    jump_open_ = behind_[0] || behind_[1] || behind_[2];
  }
  if (!offTimeline(input, stamp_ns)) {
    if (last_[input] && stamp_ns < *last_[input]) {
      decision.drop = Drop::OutOfOrder;
      return;
    }
    admit(input, stamp_ns);
    decision.admit = true;
    return;
  }
  if (held_ && !decision.jump && distance(stamp_ns, held_->stamp_ns) <= kConfirmNs) {
    confirmJump(now, decision);
    // This message now meets the new timeline like any other.
    place(input, stamp_ns, now, decision);
    return;
  }
  if (held_) decision.discard_held = true;
  held_ = Held{input, stamp_ns, now};
  decision.hold = true;
}

void StampGate::confirmJump(Clock::time_point now, Decision& decision) {
  const Held held = *held_;
  held_.reset();
  decision.jump = Jump{held.input, newest_.value_or(held.stamp_ns), held.stamp_ns};
  old_newest_ = newest_.value_or(held.stamp_ns);
  new_first_ = held.stamp_ns;
  newest_.reset();
  for (int i = 0; i < kInputs; ++i) behind_[i] = last_[i].has_value() && i != held.input;
  last_[held.input].reset();
  jump_open_ = behind_[0] || behind_[1] || behind_[2];
  jump_since_ = now;
  admit(held.input, held.stamp_ns);
}

bool StampGate::offTimeline(int input, int64_t stamp_ns) const {
  if (last_[input] && stamp_ns <= *last_[input] - kMinJumpNs) return true;
  return newest_ && distance(stamp_ns, *newest_) > kMaxSkewNs;
}

void StampGate::admit(int input, int64_t stamp_ns) {
  last_[input] = stamp_ns;
  if (!newest_ || stamp_ns > *newest_) newest_ = stamp_ns;
}

void StampGate::expire(Clock::time_point now, Decision& decision) {
  if (held_ && now - held_->since > kWindow) {
    held_.reset();
    decision.discard_held = true;
  }
  // An input that has not followed by now keeps its old stamps: if it does
  // move later, that is a jump of its own.
  if (jump_open_ && now - jump_since_ > kWindow) jump_open_ = false;
}

}  // namespace relocalizer_ros
