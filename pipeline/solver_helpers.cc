#include "pipeline/solver_helpers.h"

#include <functional>

#include <oneapi/tbb/flow_graph.h>

namespace dg::pipeline {

namespace flow = tbb::flow;

struct SolverHelpers::Node {
  flow::graph graph;
  flow::function_node<std::function<void()>> helper{
      graph, flow::unlimited,
      [](const std::function<void()>& work) {
        work();
        return flow::continue_msg();
      },
      flow::node_priority_t(1)};
};

SolverHelpers::SolverHelpers() : node_(std::make_unique<Node>()) {}

SolverHelpers::~SolverHelpers() { node_->graph.wait_for_all(); }

sim::HelperLauncher SolverHelpers::launcher() {
  return [node = node_.get()](std::function<void()> work) { node->helper.try_put(std::move(work)); };
}

}  // namespace dg::pipeline
