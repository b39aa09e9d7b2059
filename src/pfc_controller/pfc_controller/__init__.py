"""Average-current-control boost power factor correction (dissertation ch. III); the pfc_controller node."""
