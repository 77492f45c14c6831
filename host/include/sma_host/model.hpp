// A model of the wire and rig: the paper's parameters (params.hpp) and the effects of the
// vocabulary (effects.hpp). What a params file holds (interfaces.md) and what is identified.
#ifndef SMA_HOST_MODEL_HPP
#define SMA_HOST_MODEL_HPP

#include "sma/effects.hpp"
#include "sma/params.hpp"

namespace sma_host {

struct Model {
  sma::Params p;
  sma::Effects fx;
};

}  // namespace sma_host

#endif  // SMA_HOST_MODEL_HPP
