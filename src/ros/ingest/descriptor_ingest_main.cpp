// descriptor_ingest as a plain node (the same class the nodelet wraps).
#include "src/ros/common/node_runner.h"
#include "src/ros/ingest/descriptor_ingest.h"

int main(int argc, char** argv) {
  return bsf_vpr::RunNode<bsf_vpr::DescriptorIngest>(argc, argv, "descriptor_ingest");
}
