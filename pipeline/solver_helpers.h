#pragma once

#include <memory>

#include "sim/step_team.h"

namespace dg::pipeline {

// Where the FEM stage's solver runs its helper workers (sim::StepTeam) in a
// run: tasks of a flow-graph node whose priority is above the stages'. In
// the graph, the thread that is not stepping often has work queued (the next
// frame's tracking), so a plain task enqueued for a helper waited behind it
// and the solver stepped alone; a task of a prioritised node is taken at
// that thread's next task boundary. The next frame's front end then waits
// while the simulation steps on both cores.
class SolverHelpers {
 public:
  // Made on the thread that runs the graph, so its tasks go to the graph's arena.
  SolverHelpers();
  // Waits for helper tasks still queued (they find their run over and return).
  ~SolverHelpers();
  SolverHelpers(const SolverHelpers&) = delete;
  SolverHelpers& operator=(const SolverHelpers&) = delete;

  // Starts helper work as a task of the prioritised node. Lives as long as this.
  sim::HelperLauncher launcher();

 private:
  struct Node;
  std::unique_ptr<Node> node_;
};

}  // namespace dg::pipeline
