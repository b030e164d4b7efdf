// Internal to synth/ (namespace synth_internal): not part of the synthetic camera's interface.
// Row-parallel loops for the ray table, the tracer and the sensor (core/parallel.h).
#pragma once

#include "core/parallel.h"

namespace curvecheck::synth_internal {

using curvecheck::ThreadCount;

// body(y) for y in [0, rows) on all cores; rows are handed out in blocks of 4 as threads free up (rows that
// see only the room are cheaper than rows across the display). Exceptions as ParallelFor.
template <typename F>
void ParallelRows(int rows, const F& body) {
  ParallelFor(rows, body, 4);
}

}  // namespace curvecheck::synth_internal
