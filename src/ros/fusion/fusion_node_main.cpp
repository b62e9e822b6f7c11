// The fusion node as a plain node (the same class the nodelet wraps, handed its map the same
// way).
#include "src/ros/common/node_runner.h"
#include "src/ros/fusion/fusion_node.h"

int main(int argc, char** argv) {
  return bsf_vpr::RunNode<bsf_vpr::FusionNode, &bsf_vpr::MakeFusionNode>(argc, argv, "fusion");
}
