#pragma once

#include <string>

#include "pipeline/frame_packet.h"

namespace dg::pipeline {

// A stage as the graph sees it: a name, whether it keeps state from frame to
// frame (then it runs serially and sees frames in order), and one call per
// frame that reads the packet fields it needs and writes its own. The stage
// itself (stages/) is a plain class; an adapter of this interface owns it and
// knows which packet fields it reads and writes, and the graph knows nothing
// of either.
class PacketStage {
 public:
  virtual ~PacketStage() = default;
  virtual const std::string& name() const = 0;
  virtual bool stateful() const = 0;
  // Whether the stage spreads its own work over every core (the FEM's step
  // team, the overlays' image tiles). The graph runs a frame through a run
  // of such adjacent stages only after the frame before it has left the
  // last of them, so that each gets the cores to itself: interleaved, the
  // newer frame's work would hold back the older frame's, which is nearer
  // to being shown. The first stage of such a run is stateful, so that
  // frames enter it in order.
  virtual bool parallel_inside() const { return false; }
  // @throws anything: the graph stops, naming this stage and the frame.
  virtual void Process(FramePacket& packet) = 0;
};

// Where frames come from: reads them in order, one at a time.
class PacketSource {
 public:
  virtual ~PacketSource() = default;
  virtual const std::string& name() const = 0;
  // Fills packet.index, t_s and the frame's images; false after the last frame.
  virtual bool Read(FramePacket& packet) = 0;
  // Passes over the next frame without handing it on (a frame dropped, or
  // before the first frame of a range); false after the last frame.
  virtual bool Skip() = 0;
  virtual double fps() const = 0;
  virtual int frame_count() const = 0;  // as the container says: a bound, not a promise
};

}  // namespace dg::pipeline
