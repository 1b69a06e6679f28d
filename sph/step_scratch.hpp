#pragma once

#include <cstddef>
#include <memory>
#include <type_traits>

namespace wake {

/// Memory that the phases of a step borrow one after another (the neighbour sort's cells
/// and order, the force loop's partial sums, the predicted positions and the step's start
/// velocities): one block the size of the largest, instead of an array per phase. Each
/// phase views it as arrays of its own element type (plain values: numbers, Vec3); a view
/// is valid until the next phase writes its own (the phases never overlap).
class StepScratch {
 public:
  /// `count` elements of type T from byte `offset` (a multiple of alignof(T)) on, the block
  /// grown to hold them. Growing gives new memory (the old block is freed first: never
  /// both at once) and ends every view before; a view within the block keeps the others.
  template <class T>
  T* view(std::size_t offset, std::size_t count) {
    static_assert(std::is_trivially_destructible<T>::value && std::is_standard_layout<T>::value,
                  "StepScratch holds plain values");
    static_assert(alignof(T) <= kAlign, "StepScratch's alignment");
    reserve(offset + count * sizeof(T));
    // The block is byte storage (operator new[] of unsigned char): its elements begin their
    // life when a phase writes them.
    return reinterpret_cast<T*>(data_.get() + offset);
  }
  /// The block from byte `offset` on as T (no growth: what the last view there holds).
  template <class T>
  const T* at(std::size_t offset) const {
    return reinterpret_cast<const T*>(data_.get() + offset);
  }
  /// Bytes held.
  std::size_t bytes() const { return bytes_; }

 private:
  static constexpr std::size_t kAlign = alignof(std::max_align_t);
  void reserve(std::size_t bytes) {
    if (bytes <= bytes_) return;
    data_.reset();
    bytes_ = 0;
    data_.reset(new unsigned char[bytes]);
    bytes_ = bytes;
  }
  std::unique_ptr<unsigned char[]> data_;
  std::size_t bytes_ = 0;
};

}  // namespace wake
