#include "core/counting.hpp"

#include <list>
#include <mutex>

namespace minv {

namespace {
// Every thread's counter lives in this list until the thread ends; then it is folded into
// `retired`, so flopTotal() never loses counts.
std::mutex registry_mutex;
std::list<FlopCounts*> live;
FlopCounts retired;

struct ThreadSlot {
  FlopCounts counts;
  ThreadSlot() {
    std::lock_guard<std::mutex> lock(registry_mutex);
    live.push_back(&counts);
  }
  ~ThreadSlot() {
    std::lock_guard<std::mutex> lock(registry_mutex);
    retired += counts;
    live.remove(&counts);
  }
};
}  // namespace

FlopCounts& threadFlops() {
  thread_local ThreadSlot slot;
  return slot.counts;
}

FlopCounts flopTotal() {
  threadFlops();  // register this thread
  std::lock_guard<std::mutex> lock(registry_mutex);
  FlopCounts sum = retired;
  for (const FlopCounts* c : live) sum += *c;
  return sum;
}

void flopReset() {
  threadFlops();
  std::lock_guard<std::mutex> lock(registry_mutex);
  retired = {};
  for (FlopCounts* c : live) *c = {};
}

void StageCounter::operator()(const char* stage) {
  const FlopCounts now = flopTotal();
  const FlopCounts delta = now - last_;
  last_ = now;
  for (auto& [name, counts] : stages_)
    if (name == stage) {
      counts += delta;
      return;
    }
  stages_.emplace_back(stage, delta);
}

FlopCounts StageCounter::total() const {
  FlopCounts sum;
  for (const auto& [name, counts] : stages_) sum += counts;
  return sum;
}

}  // namespace minv
