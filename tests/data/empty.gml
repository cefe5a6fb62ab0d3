<gml spec="1.0">
  <tag>
    <drawing></drawing>
  </tag>
</gml>
