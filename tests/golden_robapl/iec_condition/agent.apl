% A start condition that is a complex event detected by the IEC (iec.rtl, an ELE rule): the
% greeting starts when visitor(P) is derived, not on the bell alone.
rules {
  bell <- true | list greet {
    external hello: act(P) [start: event(visitor(P))]
  }
}
