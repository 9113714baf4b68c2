"""What does the closed loop do on measured data? Silverbox, the cascaded tanks, the real pendulum's free swing and
the hare and lynx pelts (``sklearn_hybrid.recipes``), beside classical grey-box fits, and the tanks' and free
swing's windows studied on their own."""
