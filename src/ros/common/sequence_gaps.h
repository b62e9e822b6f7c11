// Messages lost before a node processed them, told from the gaps in each publisher's
// header.seq: roscpp and rospy number the messages a publication sends, so a message that
// a full subscriber queue (or a publisher's full queue to this node) dropped leaves a gap.
// The only way a node can count what overflowed its queue: roscpp drops silently.
//
// A number that does not follow (the publisher restarted and counts afresh, or a nodelet in
// the same process that leaves seq to the message's source) starts that publisher's count
// afresh and counts nothing. ROS-free; not thread-safe.
#pragma once

#include <cstdint>
#include <map>
#include <string>

namespace bsf_vpr {

class SequenceGaps {
 public:
  // A message numbered `seq` from `publisher`; how many of its messages were lost right
  // before it.
  uint64_t Note(const std::string& publisher, uint32_t seq) {
    auto [it, first] = last_.try_emplace(publisher, seq);
    if (first) return 0;
    const uint32_t last = it->second;
    it->second = seq;
    // A jump of more than kMaxGap is a publisher counting afresh, not a loss.
    if (seq <= last || seq - last > kMaxGap) return 0;
    const uint64_t lost = seq - last - 1;
    lost_ += lost;
    return lost;
  }
  uint64_t lost() const { return lost_; }  // since construction

 private:
  static constexpr uint32_t kMaxGap = 1u << 20;
  std::map<std::string, uint32_t> last_;
  uint64_t lost_ = 0;
};

}  // namespace bsf_vpr
